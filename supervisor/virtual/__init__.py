"""Virtual machines: simulated processes, sensors, the demo, the certificate, the virtual mill."""
