"""The parts of ``benchmarks/mls_parity.py`` (our MLS search against the paper's C++ code on identical starts):
ours.py (the starts and our search), cpp.py (the C++ run and its log), stages.py (MLS stages of a history),
significance.py (the tests), report.py (``--summarize``), locks.py (one worker per search)."""
