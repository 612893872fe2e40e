"""`hapticgraph sweep` and `hapticgraph fit`: many renders of one patch on a Dask cluster (a local
one by default). A bad sweep or axes file is `FILE:LINE: message` lines and exit 2 before anything
is submitted; a variant that fails is a row of the manifest, not a failed command."""
import json
import sys

from .common import UsageError
from ..sweeps import SweepError, fit, load_spec, sweep


def _check_cluster_options(args):
    if args.workers is not None and args.workers < 1:
        raise UsageError(f"--workers {args.workers}: give at least one worker")
    if args.scheduler and args.scheduler_file:
        raise UsageError("give --scheduler or --scheduler-file, not both")
    if args.workers is not None and (args.scheduler or args.scheduler_file):
        raise UsageError("--workers starts a local cluster; a running cluster (--scheduler) has its own workers")


def cmd_sweep(args):
    _check_cluster_options(args)
    if args.limit is not None and args.limit < 0:
        raise UsageError(f"--limit {args.limit}: expected 0 or more variants")
    if args.retry_failed and not args.resume:
        raise UsageError("--retry-failed renders again the failed variants of a sweep it resumes: give --resume too")
    spec = load_spec(args.sweep)
    if args.dry_run:
        print_table(spec)
        return 0
    notes = []          # --quiet: the notes are told only when a variant failed
    try:
        rows = sweep(spec, args.out, workers=args.workers, scheduler=args.scheduler,
                     scheduler_file=args.scheduler_file, resume=args.resume, retry_failed=args.retry_failed,
                     limit=args.limit, progress=False if args.quiet else None,
                     report=notes.append if args.quiet else None)
    except SweepError as exc:
        raise UsageError(str(exc)) from None
    statuses = rows["status"] if not isinstance(rows, list) else [r["status"] for r in rows]
    if all(s == "ok" for s in statuses):
        return 0
    for note in notes:
        print(note, file=sys.stderr)
    return 1


def print_table(spec):
    """The variant table of --dry-run: number, id and each axis's value."""
    head = ["#", "id"] + spec.axis_names
    body = [[str(v.index), v.id] + [json.dumps(x) for x in v.values] for v in spec.variants]
    widths = [max(len(r[i]) for r in [head] + body) for i in range(len(head))]
    for r in [head] + body:
        print("  ".join(c.rjust(w) if i != 1 else c.ljust(w) for i, (c, w) in enumerate(zip(r, widths))).rstrip())
    print(f"{len(spec.variants)} variant(s) of {spec.patch}, {spec.seconds:g} s each at {spec.rate:g} Hz "
          f"({spec.sampler}; features: {', '.join(spec.features) or 'none'}; audio: {spec.audio})")


def cmd_fit(args):
    _check_cluster_options(args)
    try:
        result = fit(args.patch, args.target, args.axes, out=args.out, results=args.results,
                     seed=args.seed, popsize=args.popsize, maxiter=args.maxiter, seconds=args.seconds,
                     workers=args.workers, scheduler=args.scheduler, scheduler_file=args.scheduler_file,
                     progress=False if args.quiet else None, report=(lambda text: None) if args.quiet else None)
    except SweepError as exc:
        raise UsageError(str(exc)) from None
    if args.quiet:          # the best patch is the result: written, and nothing said
        return 0
    for name, value in result.values.items():
        print(f"{name}={value!r}")
    print(f"distance {result.distance:.6g} after {result.evaluations} evaluations; best patch -> {result.patch_path}")
    return 0
