"""Pictures one looks around in: Rerun recordings of plans and episodes (:mod:`tognet.viz.rerun`)."""
