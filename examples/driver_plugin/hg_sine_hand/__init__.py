"""hapticgraph-sine-hand: an example driver plugin. `driver: sine` moves a haptic device's hand
along x(t) = amplitude·sin(2π·frequency·t), feels the force the patch sends back, and reports the
peak of that force. The kind (what the loader checks, light) is in .kind, the driver (what runs)
in .driver."""
