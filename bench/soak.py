"""The long soak of issue 16: 10,000 random edits, undos and redos through ``Session`` on lady_bug.

    .venv/bin/python bench/soak.py [--steps 10000] [--check-every 500] [--file lady_bug.xml]

Every ``--check-every`` steps the live picture is compared with a fresh build of the same document
(``tests/soak.py``) and the resident memory printed; at the end, the growth after the first 1,000
steps (target: under 200 MB) and the largest difference (at most 0.25/255).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(REPO / "tests"), str(REPO)]

from soak import PIXEL, soak  # noqa: E402

from fmr_editor.engine import setup_process  # noqa: E402
from fmr_editor.io import load_document  # noqa: E402

LADY_BUG = REPO.parent / "shared" / "data" / "orzan_xml" / "berkbavas" / "lady_bug.xml"


def main() -> None:
    setup_process()  # the engine's thread and memory policy, as the editor's
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=10_000)
    parser.add_argument("--check-every", type=int, default=500)
    parser.add_argument("--file", type=Path, default=LADY_BUG)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    started = time.perf_counter()

    def report(step: int, difference: float, resident: int) -> None:
        print(f"step {step:6,}: live - fresh {difference * 255:.4f}/255, resident {resident / 2**20:,.0f} MB, "
              f"{time.perf_counter() - started:,.0f} s", flush=True)

    checks = soak(load_document(args.file), args.steps, args.check_every, args.seed, report)
    baseline = next((resident for step, _, resident in checks if step >= 1000), checks[0][2])
    growth = (max(resident for _, _, resident in checks) - baseline) / 2**20
    worst = max(difference for _, difference, _ in checks)
    print(f"\n{args.steps:,} steps on {args.file.name}: largest difference {worst * 255:.4f}/255 "
          f"({'within' if worst <= PIXEL else 'ABOVE'} 0.25/255), resident growth after step 1,000 {growth:,.0f} MB "
          f"({'under' if growth < 200 else 'OVER'} 200 MB)")


if __name__ == "__main__":
    main()
