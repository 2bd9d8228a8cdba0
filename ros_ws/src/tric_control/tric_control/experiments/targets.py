"""The design's targets (design.md section 5), each to hold for every training seed."""

#: Table 1: the most TRIC's mean grasp cost may exceed our teacher's.
MARGIN_TO_TEACHER = 0.03
#: The design's cylinder targets for K = 30 (design.md section 5): mean cost, good and lifted of 10.
CYLINDER_TARGETS = (0.12, 9, 8)
#: Table 4: boxes TRIC opens of the 25 test and of the 25 validation boxes.
BOX_TARGET = 23
#: The design's targets for the learned value along the demonstrations (design.md section 5): the
#: mean L_g cosine over the moving steps at most, and the share of them along which f falls at
#: least.
COSINE_TARGET, FALLING_TARGET = -0.8, 0.95
