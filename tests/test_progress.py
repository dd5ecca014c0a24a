"""Progress: one bar over the work units of concurrent map_units calls (threads), counted exactly."""

from __future__ import annotations

import io
import threading

from fem2tmm.progress import UnitsBar, report_units, reporting, reporting_units


def test_units_bar_counts_the_units_of_concurrent_calls():
    stream = io.StringIO()
    bar = UnitsBar("work units on 2 workers", stream=stream)
    go = threading.Barrier(3)

    def calls(sizes):
        go.wait()
        with reporting_units(bar):
            for n in sizes:  # one map_units call after the other in this thread, as a load case makes them
                for k in range(n):
                    report_units(k + 1, n, "ray batches on 2 workers")

    threads = [threading.Thread(target=calls, args=(s,)) for s in ([3, 1, 4], [5, 9], [2, 6, 5, 3])]
    for t in threads:
        t.start()
    for t in threads:
        t.join(10.0)
    bar.close()
    total = 3 + 1 + 4 + 5 + 9 + 2 + 6 + 5 + 3
    assert bar.done == total and bar.submitted == total
    assert "work units on 2 workers" in stream.getvalue()  # one bar, named after the workers
    assert "ray batches" not in stream.getvalue()


def test_report_units_without_a_units_bar_goes_to_report():
    seen = []
    with reporting(lambda d, t, w: seen.append((d, t, w))):
        report_units(1, 2, "ray batches on 1 workers")
    assert seen == [(1, 2, "ray batches on 1 workers")]
    quiet = UnitsBar("work units", quiet=True)
    with reporting_units(quiet):
        report_units(1, 2, "x")
        report_units(2, 2, "x")
        report_units(1, 1, "x")  # the next call
    assert (quiet.done, quiet.submitted) == (3, 3)
