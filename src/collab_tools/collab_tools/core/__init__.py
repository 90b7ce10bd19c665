"""What every package shares, without ROS and without a simulator.

The workspace's three layers meet here: each package's core validates its inputs with
:mod:`.fields` and declares its nodes' parameters with :mod:`.settings`; bags, images and TF
trees are read and written with the modules below, by nodes, experiments and reports alike.

| concept | module |
|---|---|
| the one input-error type (exit code 2) | :mod:`.errors` (``ConfigurationError``) |
| validating readers for YAML fields (dotted paths) | :mod:`.fields` |
| reading input files: regular files only, size/path/UTF-8/YAML-alias/image-size bounds | :mod:`.input_files` |
| node parameters as data (type, range, dynamic) | :mod:`.settings`; the tool nodes' in :mod:`.tool_settings` |
| rosbag2 bags: writing (MCAP, metadata v9) | :mod:`.bag_writer`, :mod:`.bag_storage` (presets, chunks) |
| rosbag2 bags: message types and definitions | :mod:`.bag_types` |
| rosbag2 bags: reading, summaries, checks | :mod:`.bag_analysis`, :mod:`.bag_check` |
| rosbag2 bags: repairing a killed recording (`bag_reindex`; MCAP records) | :mod:`.bag_repair`, :mod:`.mcap_records` |
| what a recording lost (sequence gaps, queue depths) | :mod:`.recording_loss` |
| report plots from bags (scene under trajectories, simulation colours, no empty plot) | :mod:`.report_plots` |
| what a run achieved, first in every report (results, demos' outcomes, bag readers) | :mod:`.run_outcome` |
| the simulated scene a bag's plots and videos draw (walls, obstacles, robots' colours) | :mod:`.scene_layout` |
| a bag's top-view camera as MP4/GIF with markers drawn | :mod:`.video` |
| images: JPEG/PNG transport, label images | :mod:`.image_codec` |
| pinhole camera geometry (pixel <-> world) | :mod:`.camera_geometry` |
| what a fiducial sees: FOV/range edge rule, line of sight past boxes (core and bridge alike) | :mod:`.visibility` |
| TF trees (lookups through a chain of stamped transforms) | :mod:`.tf_tree` |
| scripted drive plans (the demo's driver) | :mod:`.drive_plan` |
| messages as input: malformed-input kinds, stamp checks, the /clock filter | :mod:`.input_checks` |
| sessions: a node's id for one life (`new_session`), following one sender's current session (SGCM follower, role player) | :mod:`.session_following` |
| the live view (Foxglove): topic selection, channels, ros2msg schemas, settings | :mod:`.live_view` |
| markers as plain data (the subsystems' marker sources build them) | :mod:`.marker_specs` |
| SROS2 access policies: sros2's policy format, DDS permissions and governance documents | :mod:`.sros2_policy` |

The experiments layer's shared parts (one signature, one results schema, sweeps, plots) are in
:mod:`collab_tools.experiments`; the ROS adapters (parameters, names, QoS, node life cycle,
orchestration) are the modules beside this package.
"""
