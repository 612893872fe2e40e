"""Progress bars on standard error: tqdm's when it is a terminal (or when asked), else one that
draws nothing. The offline render (graph/engine.py) and a sweep (hapticgraph/sweeps) use them."""
import sys


class NoBar:
    """A bar that draws nothing (tqdm's methods the callers use)."""

    def update(self, n):
        pass

    def set_postfix(self, **kwargs):
        pass

    def close(self):
        pass


def progress_bar(total, label, unit, enabled=None, **options):
    """A tqdm bar on stderr when it is a terminal, or when `enabled`; NoBar otherwise or for
    nothing to do. `options` go to tqdm (unit_scale, leave)."""
    if enabled is None:
        enabled = sys.stderr.isatty()
    if not enabled or total <= 0:
        return NoBar()
    from tqdm import tqdm           # tqdm is imported by a run that draws a bar, not by every run
    return tqdm(total=total, desc=label, unit=unit, file=sys.stderr, dynamic_ncols=True, **options)


__all__ = ["NoBar", "progress_bar"]
