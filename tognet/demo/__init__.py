"""What ``make run`` runs: ``tognet demo`` (cli.py) and its task part (tasks.py: scripted checks, grasp
candidates on a simulated depth image, an animated episode)."""
