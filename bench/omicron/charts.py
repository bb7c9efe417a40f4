"""Charts of bench_omicron rows (see bench/plot.py for the spec keys)."""
PEERS = ["fread", "pcl_load", "omicron", "omicron_front", "topdown_10k", "pcl_octree", "pcl_outofcore",
         "pcl_outofcore_disk"]
SPECS = [
    # Thesis Fig. 4.4: fraction of the hierarchy's nodes that exist, against time since the build
    # started (in-memory cloud, front thread on).
    dict(name="omicron_completion", title="OMiCroN: hierarchy completion over time (front thread on)",
         x="seconds", y="completion", series="p_curve", where=dict(sweep="completion"), split="input"),
    # (completion = nodes reachable from the cut's lists; a lower bound, see bench_omicron.cpp)
    # Thesis Fig. 4.2: read passes, first chunk's sort, wait for the first front, rest of the build.
    dict(name="omicron_first_render_vs_chunks", kind="stacked",
         title="OMiCroN: time to first render against sort chunks (front thread on)",
         x="p_chunks", stack=["phase_read_s", "phase_sort1_s", "phase_front_wait_s", "phase_rest_s"],
         stack_labels=dict(phase_read_s="read passes (bounds, buckets)", phase_sort1_s="first chunk sort",
                           phase_front_wait_s="until first front leaf", phase_rest_s="rest of the build"),
         ylabel="seconds", xlabel="sort chunks", where=dict(sweep="chunks"), split="points"),
    # Thesis Table 4.1: peak memory over the loaded cloud, bytes per input point.
    dict(name="omicron_memory_vs_ratio", kind="bars",
         title="OMiCroN: peak memory over the loaded cloud (B/point) by ratio and leaf collapse",
         x="p_ratio", y="peak_delta_bpp", series="p_collapse", series_fmt="leaf collapse {}", where=dict(sweep="ratio"), split="points",
         xlabel="parent point ratio", ylabel="bytes per input point",
         hlines=[(28, "target 28 B/pt")], annotate="%.1f"),
    dict(name="omicron_throughput_vs_size", title="Throughput (points/s) against cloud size, scene input",
         x="points", y="points_per_s", series="method", logx=True, logy=True,
         where=dict(sweep="main", input="scene")),
    dict(name="omicron_time_vs_peers", kind="bars", title="Build time, ours and peers (s, log)",
         x="points", y="seconds", series="method", series_order=PEERS, logy=True,
         where=dict(sweep="main"), split="input", annotate="%.2g", xlabel="points"),
    dict(name="omicron_peak_memory_vs_peers", kind="bars",
         title="Peak memory per input point (whole process, incl. the loaded cloud)",
         x="points", y="peak_total_bpp", series="method", series_order=PEERS,
         where=dict(sweep="main"), split="input", annotate="%.0f", xlabel="points", ylabel="bytes per point"),
    # Thesis Table 4.2: worklist size against frame time and first front.
    dict(name="omicron_frame_p95_vs_worklist", kind="bars",
         title="OMiCroN: front evaluation p95 (ms) during the build, by worklist size",
         x="p_worklist", y="frame_p95_ms", series="points", where=dict(sweep="worklist"),
         hlines=[(33, "33 ms")], annotate="%.2g", xlabel="worklist size (nodes)"),
]
