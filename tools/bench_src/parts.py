#!/usr/bin/env python3
"""Where a flight's instructions go, per shipped part (tools/bench, section 4).

Reads `callgrind_annotate` output (self costs, one or two runs) and sums each
function into the first part whose pattern it matches, so the parts add up to
the total the run collected (Mapper::integrate and FeatureMap::extract).

  parts.py FRAMES NAME=ANNOTATE_FILE [NAME=ANNOTATE_FILE]
"""
import re
import sys

# First match wins: seeing through before the rest of the walk.
PARTS = [
    ("depth filter", r"DepthFilter::"),
    ("sky filter", r"SkyFilter::|mark_sky|count_candidates"),
    ("depth codes, range table", r"Mapper::classify|convert_row|DepthRangeTable::"),
    ("seeing through", r"ProjectiveIntegrator::(any_ray_free_across|near_peak_value|"
     r"reaches_near_peak_behind|exact_at_edge)"),
    ("walk: exact values", r"ProjectiveIntegrator::exact_value"),
    ("walk: bounds, probes, rest", r"ProjectiveIntegrator::"),
    ("blur", r"LocalGrid::(finish|blur|free_cells)|blur_row"),
    ("range weighting", r"weight_occupancy_by_range"),
    ("fusion, zones", r"ZoneMap::|LocalGrid::|memset"),
    ("halo trim", r"PeakTrim::"),
    ("ground band", r"FeatureMap::(compute_terrain|scan_columns|column_surface|"
     r"keep_surface_windows|borrow_terrain_where_unseen|compute_ground_top|band_)|window_min"),
    ("extraction: boxes", r"FeatureMap::|ZoneSnapshot::|Quadtree|HeightProfile"),
    ("other", r""),
]
LINE = re.compile(r"^\s*([\d,]+)\s+(?:\([\s\d.]+%\)\s+)?(\S.*)$")


def read(path):
    sums = {name: 0 for name, _ in PARTS}
    total = 0
    in_table = False
    with open(path) as f:
        for line in f:
            if "file:function" in line:
                in_table = True
                continue
            if not in_table:
                continue
            m = LINE.match(line)
            if not m:
                if line.startswith("---") and total:
                    break
                continue
            cost = int(m.group(1).replace(",", ""))
            function = m.group(2)
            total += cost
            for name, pattern in PARTS:
                if re.search(pattern, function):
                    sums[name] += cost
                    break
    return sums, total


def main():
    frames = int(sys.argv[1])
    runs = [arg.split("=", 1) for arg in sys.argv[2:]]
    results = [(name, *read(path)) for name, path in runs]
    header = "%-28s" % "part (M instr a frame)" + "".join("%12s" % name for name, _, _ in results)
    if len(results) == 2:
        header += "%10s" % "ratio"
    print(header)
    rows = [(part, [sums[part] / frames / 1e6 for _, sums, _ in results]) for part, _ in PARTS]
    rows.append(("total", [total / frames / 1e6 for _, _, total in results]))
    for part, values in rows:
        line = "%-28s" % part + "".join("%12.2f" % v for v in values)
        if len(values) == 2:
            line += "%10s" % ("%.3f" % (values[0] / values[1]) if values[1] > 0 else "-")
        print(line)


if __name__ == "__main__":
    main()
