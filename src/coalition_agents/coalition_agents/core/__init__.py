"""Pure-Python core of the executable-coalition subsystem (IQ-ASyMTRe), no ROS imports.

Paper: Y. Zhang and L. E. Parker, "IQ-ASyMTRe: Forming Executable Coalitions for Tightly
Coupled Multirobot Tasks", IEEE Transactions on Robotics, doi:10.1109/TRO.2012.2228135 (short name
``iq_asymtre_coalitions``; the reference is in CITATION.cff).

Concepts
--------
Robots are built from schemas: environmental sensors with their perceptual schemas (ES-EPS),
perceptual schemas that convert information (reduction PSs, RPS), motor schemas (MS) that a
task activates and communication schemas (CS) that move information between robots. Schemas
are connected by *information instances* such as ``F_R(X, local)`` -- an information type
(label + number of referents) whose referents are entities (``local`` = the reasoning robot,
objects such as ``goal``) or variables instantiated later from the information actually
retrieved. For a task's MS a robot builds a *solution space* (an and-or tree of every way to
obtain the MS's inputs), takes its *potential solutions* in non-descending cost, and
instantiates them with what its sensors retrieve now and what other robots offer in answer
to its requests: a potential solution that can be instantiated consistently (the same
variable, the same entity) is an *executable* coalition; helpers reason the same way,
recursively, and the cheapest coalition (including the helpers' coalitions) is chosen.

Where the paper is implemented
------------------------------
===========================================  ==================================================
Paper                                        Module (main names)
===========================================  ==================================================
Def. 4.1 information type                    information (InformationType, InformationTypes)
Def. 4.2 information instance, referents     information (InformationInstance, Entity, Variable,
                                             LOCAL, parse_instance)
Def. 4.3 generality partial order            information (is_more_general, has_same_generality,
                                             compare_generality)
Def. 4.4/4.5, Lemma 4.1 conversions, IQ form  information (split_conversion), schemas (Conversion)
Table I RPSs                                 config/coalitions/schemas.yaml, schemas
                                             (load_library)
ES, EPS, PS, RPS, MS, CS; costs (Sec. V-A)   schemas (SchemaKind, SensorSchema, Conversion, Costs,
                                             load_costs); config/coalitions/costs.yaml
A robot's capabilities                       capabilities (RobotCapabilities,
                                             load_capability_file, capability_file_from_text)
Tasks; Table II; Fig. 4/10; Fig. 8           tasks (Task, load_tasks); config/coalitions/tasks.yaml
Sec. IV-C solution space, and-or tree, tOR   potential_solutions (RequirementNode = tOR,
                                             SchemaNode, PotentialSolution, SolutionStep)
Referent instantiation constraint (fn. 6)    schemas (Conversion.inputs_for), information
                                             (match_template, bind_to_ground), coalition
                                             (RobotReasoner.local_coalition_solutions)
Generality Imposition, Lemma 4.2             solution_constraints (generality_imposition_allows,
                                             Constraints.generality_reading)
Localness in Reasoning                       solution_constraints (localness_allows)
External Communication                       solution_constraints (external_communication_allows)
Algorithm 1                                  solution_space (SolutionSpaceGenerator.expand)
Potential solutions in non-descending cost   solution_space (SolutionSpace.iter_potential_solutions)
Removal of dominated solutions (Sec. V-A-1)  potential_solutions (information_key)
Table III                                    SolutionSpaceGenerator.motor_schema_space('navigate',
                                             [F_G(local)]) for capabilities/table3_robot.yaml
Def. 4.6-4.9 (local) coalition (solution)    coalition_solution (LocalCoalitionSolution,
                                             CoalitionSolution, coalition_members)
Coalition cost, footnote 14, Table V         coalition_solution (coalition_cost); across robots
                                             agent_spaces (coalition_cost_from_offers)
Footnote 9 (answering a request)             requests (request_variants)
Footnote 10 (self-requests), addressing      requests (addressees)
Offers (a helper's answer, its LCS)          coalition_solution (InformationOffer)
Distinct Requests, Lemma 4.3                 requests (RequestLedger), coalition_search
Algorithm 2 (one robot, step by step)        coalition (RobotReasoner.plan_task, plan_reply,
                                             local_coalition_solutions, offer, coalition)
Algorithm 2 (a team, in one process)         coalition_search (CoalitionSearch, StaticSensing)
Algorithm 2 (one robot, distributed)         agent (SchemaAgent), agent_spaces (FeasibleCoalition,
                                             reply spaces, incremental evaluation)
Algorithm 2's memos (agent and team search)  reasoning_caches (OfferBook: memoised offer view,
                                             AnswerMemo: answers_request remembered)
Sec. V: an agent's life cycle (search time,  lifecycle (AgentLifecycle: start, settle rule,
negotiate, set up, execute, re-form)         negotiation fallback, commitment, re-forming),
                                             agent_state (AgentState, StatusReport); its ports
                                             coalition_ports (LifecyclePort, CoalitionChannel);
                                             the schema_agent node drives it
Capability sharing: a robot in several       coalition_sharing (Use, CoalitionPart, conflict,
coalitions (fn. 1, 13, 14, 16, Sec. V-A-3)   solution_parts, team_sharing); coalition_serving
                                             (Commitments: held coalitions, admission rule)
Executing a coalition: information flows,    coalition_runner (CoalitionRunner: streaming,
MSs (Sec. IV-C, V-A-5, Fig. 9/11)            motor-schema steps), information_values (evaluate),
                                             value_fields (VALUE_FIELDS), motor_schema (GoToGoal,
                                             BoxPush, MaintainRelativePosition)
Re-forming when feasibility changes          coalition_execution (CoalitionExecution)
Live sensor reports -> sensed instances      live_sensing (LiveSensing)
Fig. 7 sensing model (FOV, range)            geometric_sensing (GeometricSensing, FieldOfView)
Fig. 7 / Fig. 9 simulated scenarios          sim_scenarios (column_placements, bridge_scenario)
Sec. V-B-4 / Fig. 9 message delay and loss   transport.link_model (LinkModel, DelayDistribution)
Agent channel messages                       transport.codec (ChannelCodec, ChannelMessage,
                                             MessageKind), transport.batching (Outbox, batches),
                                             transport.batch_columns (a batch's wire columns)
Request-and-wait negotiation, retries        transport.commitments (CommitmentLedger,
                                             Negotiation), transport.retry (RetryPolicy),
                                             transport.reliable_channel (ReliableChannel)
Streamed information (Fig. 9 flows)          transport.information_stream (InformationStream)
Dead and restarted teammates (ours; the      transport.liveness (PeerLiveness: sessions, silence,
paper assumes robots never fail)             heartbeats), teammate_faults (TeammateFaults: release,
                                             re-form without the dead)
An agent's parameters (ours)                 settings (AGENT_SETTINGS, AgentSettings)
Agents sharing one process (ours)            cooperative_work (CooperativeWork): bounded,
                                             round-robin reasoning steps
Coalitions and fields of view watched live   markers (CoalitionMarkers)
(ours)
===========================================  ==================================================

Choices where the paper is silent or ambiguous (each is documented where it is made)
--------------------------------------------------------------------------------------
* Generality Imposition compares the instances an RPS *converts* (its inputs) by default, as
  the constraint is worded; the proofs of Lemmas 4.2/4.4 compare what it *produces*.
  ``Constraints(generality_reading='outputs')`` selects that reading. With the default, the
  Table III robot has exactly the paper's 11 potential solutions (costs 5, 8, 8.5, 9, 9.5,
  10.5, 11, 11.5, 11.5, 12, 12); with 'outputs' two more (cost 14) chain relative positions
  through a fourth entity.
* Table III prints F_G where F_R is meant in rows 2-4 ("EPS: F_G(X, local)" has two
  referents; F_G has one): row 2 is EPS F_R(X, local), row 3 CS F_R(local, X), row 4
  CS F_R(X, local). Rows 7/8 and 10/11 print the same leaves because "RPSs are not shown":
  they differ in their RPS structure.
* A schema's label can bind a variable of a required instance only to a variable: bindings
  flow from a requirement into the schemas below it, never sideways into sibling branches
  (information.match_template).
* An instance with no referents (F_M) counts as "all referents non-robot" (LR) and may be
  requested (EC). A priori information (a task's ``prior``) is given: its zero-cost dummy
  sensor dominates every alternative, so none are generated.
* Distinct Requests: a robot sends each request label (equal up to renaming variables) once per
  search and every later CS for it shares the answers (the paper's proof of Lemma 4.4 a).
* Requests with variables go to every robot (the requester included); a fully instantiated
  label naming robots goes to those robots; a robot never relays a label it is not named in.
* Coalition cost: a CS pair counts once, on the requester's side (footnote 14), and the task's
  helper MS is charged once per helper robot; this reproduces Table V's 16 and 17.5.
* A robot may serve several coalitions at once (the paper: "the same robots can appear in
  different coalitions"): the same reading and the same communicated information go to every
  leader; it refuses only a coalition that needs its motor schema while another runs it, or an
  aimed sensor on another referent (coalition_sharing). A leader keeps its own task meanwhile.
"""
from .errors import CoalitionError, ConfigError, InformationError, RequestError, SearchError
from .information import (
    LOCAL, Entity, EntityCatalog, InformationInstance, InformationType, InformationTypes, Variable,
    canonical_instance, compare_generality, has_same_generality, is_more_general, parse_instance,
)
from .schemas import (
    Conversion, Costs, SchemaKind, SchemaLibrary, SensorSchema, costs_from_dict, library_from_dict,
    load_costs, load_library,
)
from .capabilities import (
    CapabilityFile, RobotCapabilities, capability_file_from_dict, capability_file_from_text, load_capability_file,
)
from .tasks import Task, load_tasks, tasks_from_dict
from .solution_constraints import (
    Constraints, external_communication_allows, generality_imposition_allows, localness_allows,
)
from .potential_solutions import PotentialSolution, SolutionStep
from .solution_space import SolutionSpace, SolutionSpaceCache, SolutionSpaceGenerator
from .requests import InformationRequest, RequestLedger, addressees, request_variants, to_absolute, to_local
from .coalition_solution import (
    CoalitionSolution, InformationOffer, LocalCoalitionSolution, cheapest_per_members, coalition_cost,
    coalition_members,
)
from .coalition import RobotReasoner, SearchPlan
from .coalition_search import CoalitionResult, CoalitionSearch, SearchStats, SensingModel, StaticSensing

__all__ = [
    'LOCAL', 'CapabilityFile', 'CoalitionError', 'CoalitionResult', 'CoalitionSearch', 'CoalitionSolution',
    'ConfigError', 'Constraints', 'Conversion', 'Costs', 'Entity', 'EntityCatalog', 'InformationError',
    'InformationInstance', 'InformationOffer', 'InformationRequest', 'InformationType', 'InformationTypes',
    'LocalCoalitionSolution', 'PotentialSolution', 'RequestError', 'RequestLedger', 'RobotCapabilities',
    'RobotReasoner', 'SchemaKind', 'SchemaLibrary', 'SearchError', 'SearchPlan', 'SearchStats', 'SensingModel',
    'SensorSchema', 'SolutionSpace', 'SolutionSpaceCache', 'SolutionSpaceGenerator', 'SolutionStep',
    'StaticSensing', 'Task', 'Variable', 'addressees', 'canonical_instance', 'capability_file_from_dict',
    'capability_file_from_text', 'cheapest_per_members', 'coalition_cost', 'coalition_members',
    'compare_generality', 'costs_from_dict',
    'external_communication_allows', 'generality_imposition_allows', 'has_same_generality',
    'is_more_general', 'library_from_dict', 'load_capability_file', 'load_costs', 'load_library',
    'load_tasks', 'localness_allows', 'parse_instance', 'request_variants', 'tasks_from_dict',
    'to_absolute', 'to_local',
]
