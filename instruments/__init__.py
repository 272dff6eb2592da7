"""Keithley 6221 current source with a 2182A nanovoltmeter in Delta mode: driver and simulated bench."""
