"""Self-contained HTML reports (figures embedded) for validate and diagnose."""

from mjtrack.report.html import Report as Report
