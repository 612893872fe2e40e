"""`hapticgraph studio`: a local page that shows the running instrument, shapes it with the mouse
while it plays and writes every edit back into the patch text (docs/studio.md)."""
