"""Benchmarks: each ``bench_*.py`` module has ``main()`` printing one line per figure,
each beside a reference measured in the same run (``python -m bench [NAME ...]``)."""
