"""Training the models from demonstrations: the dataset, the noisy samples and the problem of
TRIC's value function (value, problem, samples), the DPL baseline (dpl), the shared L-BFGS and
hyper-parameters, and the whole job from bags (from_bags)."""
