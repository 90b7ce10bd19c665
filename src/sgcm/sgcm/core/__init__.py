"""Pure-Python core of Stackelberg guided collaborative manipulation (no ROS imports).

Where each part of the paper (stackelberg_guidance_sgcm.txt) lives:
- task_config.py: the task's parameters (grid, colours and goals, costs with the clutter
  rule, reward, utilities, T, gamma, p_fail) and the initial configurations (cases).
- rearrangement.py: states, actions (8 directions for the leader, 4 for the follower),
  transitions with the four failure outcomes, costs, rewards, stage utilities (Section III, V).
- stage_game.py: one stage game (Q_t^A)/(Q_t^B): the MILP (Q~_t^A) and a faster exact method.
- fse.py: forward prediction of S_1..S_T and backward dynamic programming (Section IV-A, Alg. 1).
- episode.py: the rolling-horizon loop of Algorithm 1, the greedy baseline, Table I accounting.
- follower_behaviour.py: obedient, myopic, zero-trust, random (disturbance) and adversarial followers.
- centralized.py: the joint planner giving the lower bound on rounds.
"""
