"""Charts of bench_normals rows (see bench/plot.py for the spec keys)."""
EST = "rms"  # unoriented RMS angle error, degrees
SPECS = [
    dict(name="normals_error_vs_time", title="Normals: RMS angle error against time (clean inputs)",
         x="seconds", y=EST, series="method", logx=True, where=dict(sweep="main"), split="input", scatter=True),
    dict(name="normals_error_vs_time_1m", title="Normals: RMS angle error against time, speed sweep (1M points with --full, 200k without)",
         x="seconds", y=EST, series="method", logx=True, where=dict(sweep="speed"), split="input", scatter=True),
    dict(name="normals_error_vs_noise", title="Normals: RMS angle error against noise (sigma / diagonal)",
         x="p_noise", y=EST, series="method", where=dict(sweep="noise"), split="input"),
    dict(name="normals_below10_vs_noise", title="Normals: share of errors < 10 deg against noise",
         x="p_noise", y="below10", series="method", where=dict(sweep="noise"), split="input"),
    dict(name="normals_error_vs_shadow", title="Normals: RMS angle error against shadow holes (% removed, Musmanno 2016 §6.2.1)",
         x="p_shadow", y=EST, series="method", where=dict(sweep="shadow"), split="input"),
    dict(name="normals_error_vs_density", title="Normals: RMS angle error against density gradient (min/max)",
         x="p_min_ratio", y=EST, series="method", logx=True, where=dict(sweep="density"), split="input"),
    dict(name="normals_orientation_flipped", title="Orientation: share of flipped normals against time",
         x="seconds", y="flipped", series="method", logx=True, where=dict(sweep="main"), split="input", scatter=True),
]
