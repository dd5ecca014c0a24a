"""fem2tmm's benchmarks and studies (not part of the installed package): ``python -m benchmarks.run NAME`` from
the repository root or ``fem2tmm bench NAME`` inside a checkout.  One module per stage; ``cases.py`` holds the
shared scenario builders, ``run.py`` the runner and its measurement helpers."""
