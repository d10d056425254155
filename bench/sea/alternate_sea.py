#!/usr/bin/python3
"""The analyst's whole job by sea, two binaries alternated: each round runs every case with
each binary in turn; the medians over the rounds are reported (the command's wall time, and the
report's compute and lines phases), and every output file of one binary is compared byte for
byte with the other's in every round.

The cases are the ones bench/RESULTS-sea.md has timed since session 66:
- ports:  the western Baltic's 200 ports (fixtures/baltic_west_ports.geojson) as seeds, its land
          (fixtures/baltic_west.gpkg) as barriers, geodesic, at each grid of --grids;
- states: the four states as both seeds and land, 0.02 deg;
- zealand: the ports with Zealand's at half effect (fixtures/baltic_west_ports_zealand_half.geojson),
          0.01 deg;
- oresund: the Øresund's 12 ports with the two states' land, in UTM 33N at 250 m (planar);
- gshhg (only when asked for, with --gshhg COAST,PORTS): a detailed coast, GSHHG's land of the
          same extent and 200 ports on it (gshhg_coast.py, then gshhg_ports.py), 0.02 deg.
Outputs: ownership, distance, boundaries, regions and the report; --threads 2.

usage:
  bench/sea/alternate_sea.py [--rounds 3] [--grids 0.02,0.005,0.001] [--only ports,states,zealand,oresund]
                             [--gshhg /tmp/baltic_gshhg_f.gpkg,/tmp/gshhg_ports_owned.geojson]
                             OLD_BINARY NEW_BINARY
Debian's /usr/bin/python3. Run it on an otherwise idle machine (no build beside it).
"""
import argparse
import filecmp
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
FIX = os.path.join(ROOT, "fixtures")
BALTIC = ["--extent", "9.0", "53.8", "15.5", "56.2"]
OUTPUTS = [("--ownership", "own.tif"), ("--distance", "dist.tif"), ("--boundaries", "lines.geojson"),
           ("--regions", "regions.geojson")]


def cases(grids, only, gshhg=None):
    out = []
    if "ports" in only:
        for g in grids:
            out.append((f"200 ports by sea, {g} deg",
                        [os.path.join(FIX, "baltic_west_ports.geojson"), "--owner-field", "owner", "--barriers",
                         os.path.join(FIX, "baltic_west.gpkg"), *BALTIC, "--resolution", g]))
    if "states" in only:
        out.append(("states as seeds and land, 0.02 deg",
                    [os.path.join(FIX, "baltic_west.gpkg"), "--owner-field", "iso2", "--on-conflict", "lower-code",
                     "--barriers", os.path.join(FIX, "baltic_west.gpkg"), *BALTIC, "--resolution", "0.02"]))
    if "zealand" in only:
        out.append(("Zealand's ports at half effect by sea, 0.01 deg",
                    [os.path.join(FIX, "baltic_west_ports_zealand_half.geojson"), "--owner-field", "owner",
                     "--effect-field", "effect", "--barriers", os.path.join(FIX, "baltic_west.gpkg"), *BALTIC,
                     "--resolution", "0.01"]))
    if "oresund" in only:
        out.append(("Øresund ports by sea, 250 m (planar)",
                    [os.path.join(FIX, "oresund_ports.geojson"), "--owner-field", "owner", "--barriers",
                     os.path.join(FIX, "oresund.gpkg"), "--crs", "EPSG:32633", "--extent", "330000", "6150000",
                     "370000", "6220000", "--resolution", "250"]))
    if "gshhg" in only:
        if not gshhg:
            sys.exit("alternate_sea: the gshhg case needs --gshhg COAST,PORTS (bench/sea/gshhg_ports.py)")
        coast, ports = gshhg.split(",")
        out.append(("200 ports on GSHHG's full coast by sea, 0.02 deg",
                    [ports, "--owner-field", "owner", "--barriers", coast, *BALTIC, "--resolution", "0.02"]))
    return out


def run(binary, args, directory):
    os.makedirs(directory, exist_ok=True)
    cmd = [binary, "compute", *args, "--threads", "2", "--report", os.path.join(directory, "report.json")]
    for flag, name in OUTPUTS:
        cmd += [flag, os.path.join(directory, name)]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        sys.exit(f"{binary} failed ({proc.returncode}): {proc.stderr.strip()}")
    with open(os.path.join(directory, "report.json")) as f:
        t = json.load(f)["timings_s"]
    return wall, t.get("compute", 0.0), t.get("deliverables", {}).get("boundaries", 0.0)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--grids", default="0.02,0.005,0.001")
    ap.add_argument("--only", default="ports,states,zealand,oresund")
    ap.add_argument("--gshhg", help="COAST,PORTS: the detailed coast's files (the gshhg case)")
    ap.add_argument("old")
    ap.add_argument("new")
    args = ap.parse_args()
    only = set(args.only.split(","))
    if args.gshhg:
        only.add("gshhg")
    todo = cases(args.grids.split(","), only, args.gshhg)
    times = {(label, which): [] for label, _ in todo for which in ("old", "new")}
    differ = set()
    with tempfile.TemporaryDirectory() as work:
        for rnd in range(args.rounds):
            for k, (label, cmd) in enumerate(todo):
                dirs = {}
                for which, binary in (("old", args.old), ("new", args.new)):
                    dirs[which] = os.path.join(work, f"{k}-{which}")
                    times[(label, which)].append(run(binary, cmd, dirs[which]))
                for _, name in OUTPUTS:
                    if not filecmp.cmp(os.path.join(dirs["old"], name), os.path.join(dirs["new"], name), shallow=False):
                        differ.add((label, name))
            print(f"round {rnd + 1} of {args.rounds} done", file=sys.stderr)
    print("| case | job old | job new | compute old | compute new | boundaries old | boundaries new |")
    print("|---|---|---|---|---|---|---|")
    for label, _ in todo:
        med = {w: [statistics.median(x[i] for x in times[(label, w)]) for i in range(3)] for w in ("old", "new")}
        print(f"| {label} | {med['old'][0]:.3f} s | {med['new'][0]:.3f} s | {med['old'][1]:.3f} s | "
              f"{med['new'][1]:.3f} s | {med['old'][2]:.3f} s | {med['new'][2]:.3f} s |")
    print()
    if differ:
        print("outputs that differ: " + ", ".join(f"{label}: {name}" for label, name in sorted(differ)))
    else:
        print("every output file byte for byte the same in every round")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
