"""Hardware-in-the-loop: plants that step (float, golden, RTL), controllers, the lockstep loop."""
