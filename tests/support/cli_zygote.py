"""A process that has imported mjtrack once and forks one child per command line (tests only).

Started by ``support.cli.Forker``. It reads one JSON request per line on stdin:
``{"argv": [...], "cwd": DIR, "memory": BYTES, "limit_s": S, "signal": [SIGNUM, DELAY_S] | null,
"grace_s": S}`` and answers one JSON line on stdout: ``{"rc", "stdout", "stderr", "seconds",
"signalled_at", "after_signal_s", "killed"}``.

The child runs the command as the ``mjtrack`` program does (``main()`` with ``sys.argv``): its
own process, its own signal handlers, stdout and stderr in files, the address space capped at
``memory`` (``RLIMIT_AS``). The zygote sends ``signal`` after its delay; a child still running
after ``limit_s`` gets SIGINT (a long valid run is stopped as a user would stop it), and one still
running ``grace_s`` after its first signal is killed (``killed`` true: a hang). Forking from a
warm process makes a command line cost its own work only, not the seconds of importing MuJoCo,
SciPy and Matplotlib.
"""

from __future__ import annotations

import json
import os
import resource
import signal
import sys
import tempfile
import time


def _child(req: dict, out_path: str, err_path: str) -> None:
    try:
        os.setsid()  # a group of its own: the zygote signals it (and its children) like a terminal would
        os.chdir(req["cwd"])
        for fd, path in ((1, out_path), (2, err_path)):
            f = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
            os.dup2(f, fd)
            os.close(f)
        sys.stdout = os.fdopen(1, "w", buffering=1)
        sys.stderr = os.fdopen(2, "w", buffering=1)
        mem = int(req["memory"])
        resource.setrlimit(resource.RLIMIT_AS, (mem, mem))
        signal.signal(signal.SIGINT, signal.default_int_handler)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        from mjtrack.cli import main

        sys.argv = ["mjtrack", *req["argv"]]
        rc = main()
    except SystemExit as exc:
        rc = exc.code if isinstance(exc.code, int) else 1
    except BaseException:
        import traceback

        traceback.print_exc()
        rc = 1
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    finally:
        os._exit(rc if isinstance(rc, int) else 1)


def _run(req: dict) -> dict:
    tmp = tempfile.mkdtemp(prefix="mjtrack-zygote-")
    out_path, err_path = os.path.join(tmp, "out"), os.path.join(tmp, "err")
    start = time.monotonic()
    pid = os.fork()
    if pid == 0:
        _child(req, out_path, err_path)
    plan = req.get("signal")
    sig_at = start + float(plan[1]) if plan else None
    limit_at = start + float(req["limit_s"])
    grace = float(req.get("grace_s", 5.0))
    first_signal = None
    killed = False
    status = None
    while status is None:
        done, st = os.waitpid(pid, os.WNOHANG)
        if done:
            status = st
            break
        now = time.monotonic()
        if first_signal is None and sig_at is not None and now >= sig_at:
            first_signal = now
            _kill(pid, int(plan[0]))
        elif first_signal is None and now >= limit_at:
            first_signal = now
            _kill(pid, signal.SIGINT)
        elif first_signal is not None and now >= first_signal + grace and not killed:
            killed = True
            _kill(pid, signal.SIGKILL)
        time.sleep(0.01)
    end = time.monotonic()
    rc = os.waitstatus_to_exitcode(status)
    with open(out_path, encoding="utf-8", errors="replace") as fh:
        out = fh.read()
    with open(err_path, encoding="utf-8", errors="replace") as fh:
        err = fh.read()
    for p in (out_path, err_path):
        os.unlink(p)
    os.rmdir(tmp)
    return {"rc": rc, "stdout": out[-4000:], "stderr": err[-8000:], "seconds": end - start,
            "signalled_at": None if first_signal is None else first_signal - start,
            "after_signal_s": None if first_signal is None else end - first_signal, "killed": killed}


def _kill(pid: int, sig: int) -> None:
    try:
        os.killpg(pid, sig)  # the child leads its own group (setsid): its children get it too
    except ProcessLookupError:
        pass


def main() -> None:
    import mjtrack.cli  # noqa: F401  the imports every command needs, done once
    import mjtrack.commands._common  # noqa: F401
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401
    import mujoco  # noqa: F401
    import scipy.optimize  # noqa: F401

    import mjtrack.calibrate.fit  # noqa: F401
    import mjtrack.calibrate.run  # noqa: F401
    import mjtrack.diagnose  # noqa: F401
    import mjtrack.sim.rollout  # noqa: F401
    import mjtrack.sim.windows  # noqa: F401
    import mjtrack.validate  # noqa: F401

    sys.stdout.write("ready\n")
    sys.stdout.flush()
    for line in sys.stdin:
        if not line.strip():
            continue
        res = _run(json.loads(line))
        sys.stdout.write(json.dumps(res) + "\n")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
