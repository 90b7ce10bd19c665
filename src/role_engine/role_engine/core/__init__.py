"""Pure-Python core of the role engine (RBC + GP inference), no ROS imports, no simulator.

Paper: B. Akbari, Z. Wang, H. Zhu, L. Wan, R. Adderson and Y.-J. Pan, "Role Engine Implementation
for a Continuous and Collaborative Multi-Robot System" (short name ``role_engine_gp_inference``; the
reference is in CITATION.cff).

Concepts
--------
A *role* is a destination point of a formation; its *process role* is the trajectory that plays
it, an (N+1, 4) array of evenly timed states [x, y, vx, vy] optimised by GP inference. The
central computer negotiates (per robot type: the environment view, its SDF, the E-Map and
initial paths), evaluates every agent-role pair (Q = lambda F_gp + F_conf), assigns by Group
Role Assignment and publishes the initial process roles; each robot then plays its role,
re-optimising it against the others' process roles from a shared channel, while the central
computer watches for problems and renegotiates.

Where the paper is implemented
------------------------------
=============================================  ==================================================
Paper                                          Module (main names)
=============================================  ==================================================
Eq. 1-3 MAP over a factor graph                gp_planner (GPPlanner.plan: the factors are
                                               gp_costs terms; gp_gtsam builds the graph)
Eq. 4-7 LTV-SDE, its mean and covariance       gp_prior (transition_matrix, process_covariance;
                                               interpolation_matrices: Eq. 6-7 conditioned on
                                               two support states)
Eq. 8 GP prior, Mahalanobis norm               gp_prior (prior_cost, whitening_matrix),
                                               gp_costs (GPPriorTerm)
Eq. 9 obstacle likelihood (hinge)              gp_costs (ObstacleTerm, InterpolatedObstacleTerm)
Eq. 10 inter-robot factor (MA-GPMP's idea)     gp_costs (MovingObstacleTerm,
                                               InterpolatedMovingObstacleTerm), role_playing
                                               (moving_obstacle_terms)
Eq. 11 MAP problem; Eq. 12 linearised LM step  gp_planner (GPPlanner, GPPlannerConfig);
                                               gp_compiled (the terms packed for gp_kernels: the
                                               numba LM, the default), gp_vectorised (banded
                                               normal equations, own LM), gp_gtsam
                                               (LevenbergMarquardtOptimizer, the reference)
Eq. 13 qualification q = lambda F_gp + F_conf  qualification (qualification,
                                               qualification_matrix)
Eq. 14 F_gp                                    qualification (ProcessRoleEvaluation.prior_cost;
                                               the GP evaluators: formation_task.TypedGPEvaluator,
                                               experiments.gp_sweep.GPProcessRoleEvaluator)
Eq. 15 F_conf (arc-length obstacle integral)   qualification (conflict_cost, hinge_cost)
Eq. 16-19 constant-velocity prior, Phi, Q_k    gp_prior; trajectory (cubic Hermite between
                                               states, Eq. 17's zero-acceleration mean)
Eq. 20-21 hinge loss on the SDF, epsilon       gp_costs (hinge_loss, query_sdf), sdf
                                               (SignedDistanceField; Fig. 6)
Eq. 22 motion constraints                      gp_costs (StatePriorTerm: start/goal,
                                               VelocityLimitTerm: speed limit)
Algorithm 1 central computer                   central (plan_roles: lines 1-6); engine
                                               (RoleEngine: publish, watch, renegotiate, abort,
                                               lines 7-23); problems (ProblemWatch: Prob());
                                               top_view, tracking (the camera's view)
Algorithm 2 role negotiation                   negotiation (negotiate_roles); environment
                                               (Environment.for_robot = Env_tau, lines 2-4);
                                               sdf (Sdf_tau); emap (build_emap, line 5); astar
                                               (EMapPlanner = Find_Aux, line 9); initial_paths
                                               (Make_Init_Path, line 10; Fig. 3)
Algorithm 3 GRA and process-role init          qualification (qualification_matrix, lines 1-22),
                                               assignment (group_role_assignment, line 23),
                                               central (plan_roles, lines 24-27)
Table II assignment matrix T                   assignment (AssignmentResult.assignment, .pairs)
Algorithm 4 role-playing agent                 player (RolePlayer: subscribe, track, update,
                                               publish); conflict (find_conflicts,
                                               make_conflict_field = MakeConflictField, line 3,
                                               Fig. 5); role_playing (replan_process_role,
                                               lines 3-6); yielding (narrow passages, Fig. 12);
                                               tracking (TrackPosition, line 4)
Sec. III formations (circle, square, line,     formations (parse_formation, *_formation)
diamond)
Sec. V-B robot controller ([26])               controller (TrajectoryFollower, TrackingGains)
Appendix A-A E-Map (Figs. 16-17)               emap (skeleton_of, remove_stairs, EMap)
Appendix A-B auxiliary nodes (Fig. 18)         astar (EMapPlanner, reduce_by_line_of_sight),
                                               grid (octile_distance, line_of_sight)
Table III (E-Map vs straight line)             role_engine.experiments.table3 (with gp_sweep)
Table IV (GRA vs nearest neighbour)            role_engine.experiments.table4;
                                               assignment (nearest_neighbour_assignment)
Sec. V-A-3/4, Figs. 11-12 (task vs role        role_engine.experiments.collab (core-level
based; narrow hallway)                         simulation of the nodes' RolePlayer)
Sec. V-B, Figs. 15-16 (diamond, real robots)   role_engine.experiments.formation (the nodes
                                               in simulation, measured from the bag)
E-Map, roles and process roles watched live    markers (RoleMarkers)
(ours)
Sessions and senders of assignments and        sessions (SessionFollower: the player's rules on
process roles, restarted nodes rejoining       collab_tools.core.session_following;
(ours)                                         engine_channel_verdict); engine (RoleEngine.announced)
=============================================  ==================================================

Supporting modules (ours): ``grid`` (cell <-> world), ``environment`` (also the map files: Nav2
map YAMLs, read by ``pybullet_bridge.core.occupancy_map.read_nav2_map`` as the bridge reads them),
``occupancy`` (Environment <-> Nav2 OccupancyGrid cells), ``controller`` (the role players' path
tracking, shared by the node and roles-collab through ``player``), ``formation_task`` (the nodes' settings file, the team, the typed GP
evaluator), ``tuning`` (run-time tuning of the nodes), ``node_settings`` (the nodes' ROS
parameters as SettingsSchemas), ``errors`` (RoleEngineError, a ConfigurationError).

Choices where the paper is silent are documented where they are made: process-role velocities
at start and goal (experiments.gp_sweep), the renegotiation policy (engine, problems), the
others as time-indexed moving obstacles and detours (role_playing), who yields in a narrow
passage (yielding), arrival and pose timeout (player).
"""
