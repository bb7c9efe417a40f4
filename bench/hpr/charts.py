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
]
