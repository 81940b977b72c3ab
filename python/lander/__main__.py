"""python3 -m lander run SCENARIO --out DIR [--seed N] [--video] [--quiet] [--vision-schedule S]

The `lander run` of a scenario whose flight software is written in Python (flight.python:
FILE.py:CLASS); `lander run` hands such scenarios here. Exit codes as `lander run`: 0 the
scenario's expected outcome, 1 another outcome or a run-time failure, 2 bad input.
"""
import argparse
import sys


def main(argv=None):
    p = argparse.ArgumentParser(prog="python3 -m lander")
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="run one scenario")
    r.add_argument("scenario")
    r.add_argument("--out", required=True)
    r.add_argument("--seed", type=int)
    r.add_argument("--video", action="store_true")
    r.add_argument("--quiet", action="store_true")
    r.add_argument("--vision-schedule", default="auto", choices=["auto", "serial", "overlap"])
    a = p.parse_args(argv)
    import lander
    try:
        s = lander.run(a.scenario, seed=a.seed, out=a.out, video=a.video, vision_schedule=a.vision_schedule)
    except lander.ConfigError as e:
        print(f"lander: {e}", file=sys.stderr)
        return 2
    except Exception as e:  # the run failed at run time: summary.json says why
        print(f"lander: error: {e}", file=sys.stderr)
        return 1
    print(f"lander run: {s.get('scenario')}: {s['outcome']}\noutputs in {a.out}/")
    expected = "landed"
    return 0 if s["outcome"] in (expected, "scripted_flight_complete") else 1


if __name__ == "__main__":
    sys.exit(main())
