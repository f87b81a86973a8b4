"""What ``make run`` runs: ``tognet demo`` (:mod:`tognet.cli.demo`) and its task part (tasks.py: scripted
checks, grasp candidates on a simulated depth image, an animated episode)."""
