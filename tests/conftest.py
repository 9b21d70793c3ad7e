"""For the whole suite: the numbers tests measured (the ``report`` fixture) printed together at the end."""

from __future__ import annotations


def pytest_terminal_summary(terminalreporter) -> None:
    measured = [(report.nodeid, value) for reports in terminalreporter.stats.values() for report in reports
                if getattr(report, "when", None) == "call"  # reports (the stats also hold deselected items)
                for name, value in report.user_properties if name == "measured"]
    if not measured:
        return
    terminalreporter.section("measured")
    for nodeid, line in sorted(measured):
        terminalreporter.write_line(f"{nodeid}: {line}")
