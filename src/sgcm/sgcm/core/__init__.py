"""Pure-Python core of Stackelberg guided collaborative manipulation (no ROS, no simulator).

Paper: Y. Zhao, B. Huang, J. Yu and Q. Zhu, "Stackelberg Strategic Guidance for Heterogeneous Robots
Collaboration" (short name ``stackelberg_guidance_sgcm``; the reference is in CITATION.cff). In its
framework, Stackelberg Guided Collaborative Manipulation (SGCM), a leader arm (she, more actions, plans
ahead) guides a follower arm (he, fewer actions, myopic) through a multi-object rearrangement task by
solving a feedback Stackelberg equilibrium (FSE) over a rolling horizon and recommending his move.
The experiments (Table I, Fig. 4, Fig. 5) are in ``sgcm/experiments/``; the two ROS nodes
(leader_planner, follower_executor) drive the classes named below.

Where the paper is implemented
------------------------------
==============================================  ====================================================
Paper                                           Module (main names)
==============================================  ====================================================
Sec. III workspace cells, object types,         task_config (TaskConfig, load_task);
goals; Sec. V set-up (3x3 grid, colours,        config/sgcm/task.yaml documents every field
bottom-row goals)
Sec. III state s (objects per cell and type)    rearrangement (RearrangementModel.state_of, key);
                                                game_tables (GameTables: the game as integer and
                                                float arrays for the compiled kernel)
Sec. III actions A^A (8 directions), A^B (4),   rearrangement (ActionTable, Move, feasible,
the empty action                                can_apply, apply)
Sec. III p_fail^A, p_fail^B; the four outcomes  rearrangement (RearrangementModel.stage: outcome
(a^A,a^B), (a^A,0), (0,a^B), (0,0)              probabilities, successor_states, step)
Sec. V costs, doubled in crowded cells          task_config (RobotModel, ClutterRule),
                                                rearrangement (cost, expected_costs)
Sec. V reward "proportional to the distance     task_config (RewardModel), rearrangement (reward,
to the goal"                                    outcome_rewards, goal_state)
Stage utility u^i(s,a^A,a^B) = r - costs;       task_config (UtilityWeights),
Sec. III-A guidance by equal utilities          rearrangement (stage_utilities)
Terminal utility u_T^i(s_T) = r(s_T)            fse (FSEPlanner.plan: v_T)
J^i, discount gamma, horizon T                  task_config (TaskConfig.discount, horizon), fse
(Q_t^A), (Q_t^B(pi_t^A)): one stage game        stage_game (StageSolution; solve_fast: one LP per
                                                follower action, exact)
KKT conditions (1), big-M                       stage_game (big_m, solve_milp)
(Q~_t^B), (Q~_t^A) MIQP -> MILP with z_t        stage_game (solve_milp, HiGHS)
Sec. IV-A dynamic programming for the FSE       fse (FSEPlanner.plan: backward over S_T-1 .. S_0,
                                                the reference); fse_compiled (CompiledFSEPlanner,
                                                the default: the same on the compiled kernel;
                                                make_planner, PLANNER_PATHS)
Remark (Sec. IV-B) reachable sets S_0..S_T      fse (FSEPlanner._expand: forward prediction)
Algorithm 1 lines 3-10 forward prediction       fse (FSEPlanner._expand); fse_kernel (expand_level)
Algorithm 1 lines 11-18 dynamic programming     fse (FSEPlanner.plan), stage_game; fse_kernel
                                                (solve_level_pure: a whole stage, cooperative
                                                games settled by their maximal entry;
                                                level_games: U^A, U^B for the stage_game
                                                solvers in general-sum games)
Algorithm 1 line 19 leader executes pi_0^A*,    leader_round (LeaderRound.observe -> LeaderTurn:
recommends pi_0^B* (rolling horizon, Sec. IV-C) her move, sampled if mixed; the recommendation)
Algorithm 1 lines 20-23 observe, stop at goal   leader_round (LeaderRound.observe: goal, stuck,
                                                round limit); stuck_rule (StuckRule: the "stuck"
                                                of Table I / Fig. 3, one rule for core and nodes)
Algorithm 1, the whole loop (abstract game)     episode (run_sgcm, MoveExecutor, EpisodeResult)
Algorithm 1 on the arms (leader_planner node)   leader_rounds (LeaderRounds, LeaderPhase,
                                                LeaderPort)
Sec. V follower "senses the current situation"  follower_behaviour (Follower: obedient, myopic
and executes the recommendation; Sec. V-B       best_response, zero_trust, random disturbance,
disturbance, zero trust (Fig. 5)                adversarial), follower_rounds (FollowerRounds:
                                                the follower_executor node's rounds)
Sec. V-A greedy baseline                        follower_behaviour (greedy_action), episode
                                                (run_greedy), leader_round (strategy 'greedy')
Table I accounting (stage-wise utility, sum     episode (RoundRecord.stage_utility,
over interaction rounds)                        EpisodeResult.utility_over)
Table I from recorded runs (simulation)         round_log (LoggedRound, episode_from_log)
Table I rounds, lower bound (ours)              centralized (CentralizedPlanner: A* joint plan)
Fig. 1 / Fig. 2 the ten initial cases           task_config (Case, load_cases);
                                                config/sgcm/cases.yaml; a case's own grid and
                                                goals: task_config (case_task, task_of)
Fig. 1 simulation in PyBullet                   scenario_builder (build_scenario: the bridge's
                                                scenario of a case)
Fig. 1 set-up: the arms across the table,       workspace_layout (Workspace, place_arms: cell size
each reaching the workspace (ours: placed       and arm placement from the grid by the bridge's
from the grid, or the task refused)             arm models; reach per cell -> ActionTable)
Sec. V "perception is vision-based"             perception (estimate_state, classify_colour)
Perception judges its evidence (ours: a         perception_check (evidence_problem,
frame shows every cube of the legend in         PerceptionCheck: rejected frames, the
the grid, or it is not used)                    perception fault)
The nodes' parameters (ours)                    settings (LEADER_SETTINGS, FOLLOWER_SETTINGS,
                                                LeaderSettings, FollowerExecutorSettings)
Who a message is from (ours): sender and       sessions (FollowedLeader: the follower's rules
session of each node, the follower following    on collab_tools.core.session_following;
the current session of his leader               FollowerReports: the leader's);
                                                round_log (rounds_in_order: a recording's rounds
                                                across a restarted leader)
An arm goal the crashed bridge never answers    arm_goal (GoalWatch: timeout, server loss)
(ours)
Table I, Fig. 4, Fig. 5 experiments             sgcm.experiments (table1, disturbance)
Fig. 1 set-up watched live (ours)               markers (SgcmMarkers: grid, estimate, moves)
==============================================  ====================================================

Choices where the paper is silent (each documented where it is made)
---------------------------------------------------------------------
* Feasibility, relays, blocked follower moves and the cost of failed moves: rearrangement.
* A robot's action set holds only moves between cells its arm reaches: rearrangement (ActionTable),
  from workspace_layout (where the arms stand, cell and cube sizes for grids up to 10 x 10).
* Tie-breaking among equilibria (strong Stackelberg, then the follower's value, then the lowest
  follower action, a pure leader strategy when one attains the values): stage_game; the kernel's
  cooperative shortcut repeats it (maximal entry, lowest follower action, then lowest leader
  action, within the solver's tolerance): fse_kernel.
* When a task is stuck (the paper's greedy "gets stuck in the last state", Fig. 3): stuck_rule --
  a state comes back after rounds in which nothing was left to chance (no failure possible or
  seen, no random draw), which includes a round with both arms idle.
"""
