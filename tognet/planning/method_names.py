"""The methods' names alone (no imports), for help texts that must load fast; the table with what each
method is lives in :mod:`tognet.planning.methods`, which checks that it lists these, in this order."""

#: Every method in the table's order: the paper's baselines, TOG-Net, the learned action search, the
#: action search checked in the image's twin, the Oracle, Oracle+ (the stronger bound), then the diagnostics.
METHOD_NAMES = ("Antipodal+Random", "Task_Agn+Random", "Task_Agn+Trained", "Task_Ori+Random", "TOG-Net",
                "TOG-Net+ActionSearch", "TOG-Net+Twin", "Oracle", "Oracle+", "TOG-Net grasp + Oracle motion",
                "Oracle grasp + TOG-Net motion")
#: The rows that read the simulator's ground truth for one half of the plan (neither baselines nor
#: methods a robot could run).
DIAGNOSTIC_NAMES = ("TOG-Net grasp + Oracle motion", "Oracle grasp + TOG-Net motion")
