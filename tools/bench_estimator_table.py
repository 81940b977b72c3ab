#!/usr/bin/env python3
"""Markdown tables of a `lander bench estimator --json F` result, as the README shows them.

    python3 tools/bench_estimator_table.py F.json

Per group (overall, by altitude, blur, tilt, the views whose ring sets are all >= 4 px
across): detections / frames, mean / p95 / max position error, gross poses (position error
above 5 % of the range) for ours, AprilTag, ArUco and ArUco + subpix; then the rows where
ours detects fewer views than AprilTag or has the larger mean position error. A missing key
is an error (the JSON is from another version), not a blank.
"""
import json
import sys

METHODS = [("ours", ("ours",)), ("AprilTag", ("apriltag",)), ("ArUco", ("aruco",)),
           ("ArUco + subpix", ("aruco", "subpix"))]


def at(j, path):
    for k in path:
        if not isinstance(j, dict) or k not in j:
            raise KeyError("missing key " + ".".join(path))
        j = j[k]
    return j


def cell(s):
    det, n = at(s, ("detected",)), at(s, ("frames",))
    if det == 0:
        return f"{det}/{n}, -"
    mean, p95, mx = (at(s, (k,)) for k in ("pos_err_m_mean", "pos_err_m_p95", "pos_err_m_max"))
    gross = at(s, ("gross_poses",))
    return f"{det}/{n}, {mean:.4f} / {p95:.4f} / {mx:.3f}" + (f", **{gross} gross**" if gross else "")


def groups(j):
    ours = at(j, ("ours",))
    out = [("all views", ("overall",))]
    if "rings_resolvable" in ours:
        out.append(("ring sets >= 4 px", ("rings_resolvable",)))
    for key, label, unit in (("by_altitude_m", "altitude", "m"), ("by_blur_px", "blur", "px"),
                             ("by_tilt_deg", "tilt", "deg")):
        for k in sorted(at(ours, (key,)), key=float):
            out.append((f"{label} {k} {unit}", (key, k)))
    return out


def main(argv):
    if len(argv) != 2:
        sys.exit("usage: bench_estimator_table.py BENCH.json")
    with open(argv[1]) as f:
        j = json.load(f)
    rows = groups(j)
    print("| group | " + " | ".join(m for m, _ in METHODS) + " |")
    print("|---|" + "---|" * len(METHODS))
    worse = []
    for label, path in rows:
        stats = [at(j, mp + path) for _, mp in METHODS]
        print(f"| {label} | " + " | ".join(cell(s) for s in stats) + " |")
        ours, tag = stats[0], stats[1]
        if at(ours, ("detected",)) < at(tag, ("detected",)):
            worse.append(f"{label}: ours detects {at(ours, ('detected',))}, "
                         f"AprilTag {at(tag, ('detected',))}")
        om, tm = ours.get("pos_err_m_mean"), tag.get("pos_err_m_mean")
        if om is not None and tm is not None and om > tm:
            worse.append(f"{label}: ours mean position error {om:.4f} m, AprilTag {tm:.4f} m")
    fp = [(m, at(j, mp + ("overall", "false_positives")), at(j, mp + ("overall", "empty_frames")))
          for m, mp in METHODS]
    print()
    print("False positives on target-free frames: " +
          ", ".join(f"{m} {n}/{e}" for m, n, e in fp))
    print()
    print("Rows where ours is behind AprilTag:" if worse else "Ours is ahead of AprilTag in every row.")
    for w in worse:
        print("- " + w)


if __name__ == "__main__":
    main(sys.argv)
