"""Contact mechanics of rough surfaces, the contact database and the piston/liner rig model (no pyvisa here)."""
