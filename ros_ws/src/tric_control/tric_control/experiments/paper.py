"""Every number the experiments quote from the paper (Jetchev & Toussaint), and what the report
quotes as the paper's result of each experiment."""

#: Table 1: mean grasp cost on the 15 sphere test situations, the teacher and TRIC.
PAPER_TEACHER, PAPER_TRIC = 0.06, 0.08
#: Table 2: mean joint speed |u| and DPL's training and test errors, rad per step.
PAPER_DPL_SPEED, PAPER_DPL_TRAINING, PAPER_DPL_TEST = 0.009, 0.002, 0.006
#: Table 4: boxes opened of 25.
PAPER_BOXES = {"TRIC": 24, "DPL joint space": 2, "DPL finger space": 9, "teacher": 25}
#: Fig. 16: the count of selected features (Sec. 5.5.1, Fig. 16).
PAPER_SELECTED_FEATURES = 38
#: The paper's result of each experiment, as the report quotes it beside ours.
PAPER_REPORTS = {
    "table1": f"teacher {PAPER_TEACHER} +- 0.01, TRIC {PAPER_TRIC} +- 0.01",
    "fig8": "N = 3 already grasps well; M matters more than N; M = 60 is enough (saturates); "
    "both loss terms (alpha_n = alpha_g = 1) are best",
    "table2": f"joint speed {PAPER_DPL_SPEED} +- 0.001 rad, training error {PAPER_DPL_TRAINING} "
    f"+- 0.001, test error {PAPER_DPL_TEST} +- 0.001: the training error much smaller than the "
    "test error (more data needed to generalize)",
    "fig9": "DPL degrades with the shift; TRIC stays near the teacher",
    "table3": "teacher 0.07, TRIC K = 0 0.19, TRIC K = 30 0.09",
    "exp4": "TRIC finds another grasp around the obstacle, without collision",
    "table4": f"TRIC {PAPER_BOXES['TRIC']}, DPL joint {PAPER_BOXES['DPL joint space']}, DPL finger "
    f"{PAPER_BOXES['DPL finger space']}, teacher {PAPER_BOXES['teacher']}",
    "analysis": "f decreases along every demonstration (Fig. 13); most cosines near -1, worse "
    "after t > 30 (Fig. 14a), where the collision costs rise (Fig. 14b); the goal states close "
    f"together in the hidden layer z (Fig. 15); about {PAPER_SELECTED_FEATURES} features "
    "selected, the top ones distances from the fingers to the target (Fig. 16); the mean "
    "gradients change over time, the 8th feature's sign among them (Fig. 17); box openings "
    "structured in the fingers' space in the box frame (Fig. 12)",
}
