"""hapticgraph: physical-model haptic musical instruments, compiled to one single-sample kernel."""
