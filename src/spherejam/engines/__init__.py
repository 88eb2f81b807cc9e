"""The compression engines: Lubachevsky–Stillinger (LS), the closest-jamming search (MLS) and force-biased (FB),
run by one step loop with one checkpoint protocol (:mod:`.driver`) and summarised by one typed result
(:mod:`.result`). Their numba code is in :mod:`.kernels`."""
