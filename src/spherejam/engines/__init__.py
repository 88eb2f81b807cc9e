"""The compression engines: Lubachevsky–Stillinger (LS), the closest-jamming search (MLS) and force-biased (FB),
run by one window loop with one checkpoint protocol (:mod:`.driver`). Their numba code is in :mod:`.kernels`."""
