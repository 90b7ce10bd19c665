"""Pure-Python core of the role engine (no ROS imports).

One module per concept; import what you need from the module itself:
``environment`` (map, per-type view), ``sdf``, ``emap``, ``astar`` (auxiliary nodes),
``initial_paths``, ``formations``, ``qualification`` (Eq. 13-15), ``assignment`` (GRA, NN),
``negotiation`` (Algorithm 2), ``central`` (Algorithms 1 and 3).
"""
