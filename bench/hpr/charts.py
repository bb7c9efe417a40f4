"""Charts of bench_hpr rows (see bench/plot.py for the spec keys)."""
SPECS = [
        dict(name="hpr_f1_vs_time", title="HPR: F1 against time (all methods)", x="seconds", y="f1",
             series="method", logx=True, where=dict(sweep="main"), split=["input", "points"], scatter=True),
        dict(name="hpr_f1_vs_k", title="HPR angular grid: F1 against k", x="p_k", y="f1",
             series="method", logx=True, where=dict(sweep="grid_k"), split=["input", "points"]),
        dict(name="hpr_f1_vs_noise", title="HPR: F1 against noise (sigma / diagonal)", x="p_noise", y="f1",
             series="method", where=dict(sweep="noise"), split="input"),
        dict(name="hpr_f1_vs_density", title="HPR: F1 against density gradient (min/max density)",
             x="p_min_ratio", y="f1", series="method", logx=True, where=dict(sweep="density"), split="input"),
    # Where HPR fails: F1 from 1.2x to 1000x the diagonal (same direction), every
    # method calibrated, Open3D at its best R per distance (bench_hpr --distance-sweep).
    dict(name="hpr_f1_vs_distance", title="HPR: F1 against viewpoint distance (x diagonal)", x="p_distance",
         y="f1", series="method", logx=True, where=dict(sweep="distance"), split=["input", "points"]),
    dict(name="hpr_time_vs_distance", title="HPR: seconds against viewpoint distance (x diagonal)",
         x="p_distance", y="seconds", series="method", logx=True, logy=True, where=dict(sweep="distance"),
         split=["input", "points"]),
    # Threads on a loaded machine: mean of 5 runs at 1, 2 and automatic threads, alone
    # (competitor=none) and with a spinning child process (competitor=busy_child) (bench_hpr --load-rows).
    dict(name="hpr_threads_under_load", kind="bars", title="HPR: mean seconds by OpenMP threads",
         x="p_threads", y="seconds", series="method", logy=True, where=dict(sweep="load"),
         split=["p_competitor", "points"], xlabel="threads (auto = setNumberOfThreads (0))"),
    # The wide set (bunny, fertility, torus scene, fins; 100k / 1M / 3M, two
    # views; bench_hpr --wide): F1 against seconds for every method, Open3D at R = 10^2..10^4 d.
    dict(name="hpr_wide_f1_vs_time", title="HPR wide set: F1 against time (both views)", x="seconds", y="f1",
         series="method", logx=True, where=dict(sweep="wide"), split=["input", "points"], scatter=True, cols=4),
]
