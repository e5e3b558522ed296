"""Press the probe onto the plate with PTWL, relieve the press with RWE, back off with PTWL.

    ptwl serve &                                  # or point --url at the link proxy
    python -m ptwl.experiments.press_and_relieve [--url http://127.0.0.1:8000] [--token T]

Prints each command's exit condition and forces, as the paper's tables count them.
"""

import argparse
import os
from typing import Any

from server.client import RobotClient

GAP_TO_PLATE_M = 0.0386  # probe tip to plate at the `surface` scene's home pose


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--url", default="http://127.0.0.1:8000")
    parser.add_argument("--token", default=os.environ.get("PTWL_TOKEN"))
    args = parser.parse_args()
    with RobotClient(args.url, token=args.token) as robot:
        robot.reset_scene("surface")
        steps: list[tuple[str, str, dict[str, Any]]] = [
            # 40 mm past the plate at ~10 mm/s: the 15 N limit ends it.
            (
                "press",
                "ptwl",
                {"translation": [0, 0, GAP_TO_PLATE_M + 0.04], "duration": 8.0, "force_threshold": 15.0},
            ),
            ("relieve", "rwe", {"duration": 1.0}),
            ("back off", "ptwl", {"translation": [0, 0, -0.03], "duration": 2.0}),
        ]
        for label, kind, params in steps:
            done = robot.run(kind, timeout=60.0, **params)
            fz = done.final_wrench[2] if done.final_wrench else float("nan")
            print(
                f"{label:9s} {kind:5s} -> {done.exit:13s} peak {done.peak_force:5.1f} N, "
                f"final fz {fz:+6.2f} N, {done.duration:.2f} s"
            )


if __name__ == "__main__":
    main()
