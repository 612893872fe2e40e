"""What the benchmark scripts share: the machine's description and the environment of the
`hapticgraph` processes they time."""
import os
import platform


def cpu_model():
    """The CPU's model name (Linux /proc/cpuinfo), else what platform knows."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def child_env(**extra):
    """os.environ for a timed `hapticgraph` child, plus `extra`, without PYTHONDONTWRITEBYTECODE:
    some sandboxes and CI images set it, and then every run compiles hapticgraph's modules from
    source (about 0.15 s on the reference VM). A user's Python writes the bytecode on the first
    run, and a package installed with pip ships it; the untimed first run of each benchmark
    writes it here."""
    env = dict(os.environ, **extra)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env
