"""Training the end-to-end learned baselines RL, MCL and ACL with PPO (PyTorch, CPU) on training worlds, exported
as the weights files the Rust built-in planners run (``planners/learned/POLICY.md``).

``python -m vertibench.train rl|mcl|acl --task-set DIR --out DIR`` (:mod:`.cli`); the pieces:
:mod:`.policy` (network, export), :mod:`.ppo` (PPO), :mod:`.curriculum` (uniform, manual stages, prioritized level
replay), :mod:`.worlds` (task sets, held-out worlds, the Rust features, evaluation), :mod:`.loop` (the training
loop, checkpoints), :mod:`.report` (curve and card) and :mod:`.planner` (a weights file as a Python planner). Needs ``pip install 'vertibench[train]'``.
"""
