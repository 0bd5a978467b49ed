"""The one JSON writer of results (mjtrack.io.jsonfile.write_json / json_value)."""

from __future__ import annotations

import json

import numpy as np

from mjtrack.io.jsonfile import json_value, write_json


def test_numpy_values_nan_and_keys_become_strict_json(tmp_path):
    value = {
        "f": np.float32(0.5), "d": np.float64(-2.25), "i": np.int64(7), "u": np.uint8(3), "b": np.bool_(True),
        "pb": False, "nan": float("nan"), "inf": np.float64(np.inf), "arr": np.array([[1.5, np.nan], [np.inf, 0.0]]),
        "iarr": np.arange(3), "scalar_arr": np.array(4.0), "tup": (1, np.float64(2.0)), 3: "int key",
        np.int64(4): ["numpy key"], "s": "text", "none": None,
    }
    path = tmp_path / "out.json"
    write_json(path, value, sort_keys=True)
    text = path.read_text()
    assert text.endswith("}\n")
    # Python's parser accepts the bare NaN / Infinity tokens strict JSON lacks: checked on the text
    assert "NaN" not in text and "Infinity" not in text
    back = json.loads(text)
    assert back == {
        "f": 0.5, "d": -2.25, "i": 7, "u": 3, "b": True, "pb": False, "nan": None, "inf": None,
        "arr": [[1.5, None], [None, 0.0]], "iarr": [0, 1, 2], "scalar_arr": 4.0, "tup": [1, 2.0],
        "3": "int key", "4": ["numpy key"], "s": "text", "none": None,
    }
    assert type(back["i"]) is int and type(back["b"]) is bool and type(back["iarr"][0]) is int
    assert list(back) == sorted(back)


def test_json_value_leaves_the_input_unchanged_and_keeps_types():
    value = {"a": [np.float64(np.nan)], "b": (np.int32(1),)}
    out = json_value(value)
    assert out == {"a": [None], "b": [1]}
    assert type(out["b"][0]) is int and np.isnan(value["a"][0]) and isinstance(value["b"], tuple)
    assert json_value(np.bool_(False)) is False and json_value(True) is True
