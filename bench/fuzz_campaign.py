"""A long fuzzing campaign against the loaders, the engine and the renderer (issue 16).

    .venv/bin/python bench/fuzz_campaign.py --inputs 10000 [--first-seed 0] [--memory-gb 3] [--seconds 20]
                                            [--inputs-per-worker 100]

Mutates sample files (``tests/mutations.py``: byte flips, truncation, hostile attribute values,
repeated and dropped elements, control points snapped onto a few points, ``.fmr`` members and JSON
values) and hands each input to a worker process limited to ``--memory-gb`` of address space; an input
that takes longer than ``--seconds`` is a hang (its worker is killed and replaced).  A worker is replaced
by a new process after ``--inputs-per-worker`` inputs too, so that many inputs meet a process whose
kernels are not loaded yet (as a user's first render does: the time limit includes loading them).  The
engine uses every core: run one campaign at a time, or a slow input near the limit becomes a hang.  Each
input ends as ``accepted`` (built, rendered, finite), ``refused`` (the documented error) or a failure:
``unclean`` (any other exception), ``non-finite``, ``memory`` (MemoryError), ``hang`` or ``crash`` (the
worker died).  Prints each failure as it comes and a summary by failure signature, and writes the failing
inputs to ``--keep`` for a look.

The seeds are the Orzan files of ``../shared/data`` that build in about a second (and ``.fmr`` files
saved from them), plus the repository's sample.
"""

from __future__ import annotations

import argparse
import collections
import json
import resource
import select
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))
sys.path.insert(0, str(REPO))

from mutations import mutated  # noqa: E402

SHARED = REPO.parent / "shared" / "data" / "orzan_xml"
#: Seed files: small enough that a worker builds each in about a second.
SEED_NAMES = ["handmade/arch.xml", "handmade/circles.xml", "handmade/endcap.xml", "handmade/test3.xml",
              "handmade/PortalDemo.xml", "berkbavas/lady_bug.xml", "berkbavas/poivron.xml", "berkbavas/zephyr.xml"]

WORKER = """
import json, sys, traceback
sys.path[:0] = [{tests!r}, {repo!r}]
from mutations import outcome
from fmr_editor.engine import setup_process
setup_process()
for line in sys.stdin:
    try:
        result = outcome(line.strip())
    except AssertionError as error:
        result = "non-finite: " + str(error)[:80]
    except MemoryError:
        result = "memory"
    except BaseException as error:
        frame = traceback.extract_tb(error.__traceback__)[-1]
        result = f"unclean: {{type(error).__name__}} at {{frame.filename.rsplit('/', 1)[-1]}}:{{frame.lineno}}"
    print(json.dumps(result), flush=True)
"""


class Worker:
    """A worker process under a memory limit, reading input paths on stdin and answering one line each."""

    def __init__(self, memory: int) -> None:
        def limit() -> None:
            resource.setrlimit(resource.RLIMIT_AS, (memory, memory))

        code = WORKER.format(tests=str(REPO / "tests"), repo=str(REPO))
        self.process = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                        stderr=subprocess.DEVNULL, text=True, preexec_fn=limit)

    def check(self, path: Path, seconds: float) -> str:
        self.process.stdin.write(f"{path}\n")
        self.process.stdin.flush()
        ready, _, _ = select.select([self.process.stdout], [], [], seconds)
        if not ready:
            self.close()
            return "hang"
        line = self.process.stdout.readline()
        if not line:
            code = self.process.wait()
            return f"crash: exit {code}"
        return json.loads(line)

    @property
    def alive(self) -> bool:
        return self.process.poll() is None

    def close(self) -> None:
        self.process.kill()
        self.process.wait()


def seeds(folder: Path) -> list[Path]:
    """The seed files: shared Orzan files, ``.fmr`` files saved from them, and the repository's sample."""
    from fmr_editor.engine import build
    from fmr_editor.io import load_document, save_fmr

    files = [SHARED / name for name in SEED_NAMES if (SHARED / name).is_file()]
    files.append(REPO / "resources" / "samples" / "ribbon.xml")
    saved = []
    for path in files[-3:]:
        document = load_document(path)
        saved.append(save_fmr(folder / f"{path.stem}.fmr", document, build(document)))
    return files + saved


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--inputs", type=int, default=10_000)
    parser.add_argument("--memory-gb", type=float, default=3.0)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--inputs-per-worker", type=int, default=100,
                        help="inputs a worker process takes before a new one replaces it (default 100)")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--keep", type=Path, default=Path(tempfile.gettempdir()) / "fmr-fuzz-failures")
    args = parser.parse_args()
    memory = int(args.memory_gb * 2**30)
    args.keep.mkdir(parents=True, exist_ok=True)
    counts: collections.Counter = collections.Counter()
    signatures: collections.Counter = collections.Counter()
    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        files = seeds(scratch)
        contents = [(path.suffix, path.read_bytes()) for path in files]
        worker = Worker(memory)
        try:
            for number in range(args.inputs):
                seed = args.first_seed + number
                suffix, data = contents[seed % len(contents)]
                kind, mutant = mutated(data, suffix, seed, slow=True)
                path = scratch / f"input-{seed}-{kind}{suffix}"
                path.write_bytes(mutant)
                result = worker.check(path, args.seconds)
                if not worker.alive or (number + 1) % args.inputs_per_worker == 0:
                    worker.close()
                    worker = Worker(memory)
                counts[result.split(":")[0]] += 1
                if result not in ("accepted", "refused"):
                    signatures[f"{kind}{suffix}: {result}"] += 1
                    print(f"input {seed} ({kind} of {files[seed % len(files)].name}): {result}", flush=True)
                    path.replace(args.keep / path.name)
                else:
                    path.unlink()
                if (number + 1) % 500 == 0:
                    print(f"{number + 1:,} inputs, {time.perf_counter() - started:.0f} s: {dict(counts)}", flush=True)
        finally:
            worker.close()
    print(f"\n{args.inputs:,} inputs from {len(files)} seeds in {time.perf_counter() - started:.0f} s "
          f"(the worker limited to {args.memory_gb:g} GB and {args.seconds:g} s each)")
    for outcome in ("accepted", "refused", "unclean", "non-finite", "memory", "hang", "crash"):
        print(f"  {outcome:>10}: {counts[outcome]:,}")
    for signature, count in signatures.most_common():
        print(f"  {count:6,}  {signature}")
    if signatures:
        print(f"failing inputs kept in {args.keep}")


if __name__ == "__main__":
    main()
