"""The privileged oracle: solves the goals of LIBERO's tasks from simulator state, never images,
through the 7-D OSC action every policy uses. One skill per module:

- `world`: named access to the sim (bodies, geoms, sites, joints, contacts, LIBERO's predicates);
- `motion`: closed-loop motion primitives (pose goals as OSC_POSE deltas), as action generators;
- `grasp`: grasps from the object's actual geometry, and the pick skill;
- `pick_place`: onto/into objects, fixtures and table regions, clearing obstacles on the way;
- `articulation`: the joint a region names and its open side; `drawer`, `door`, `knob`, `push`;
- `plan`: the order of skills from the BDDL goal and the current state;
- `policy`: `OraclePolicy`, the `oracle` of `vpro eval`.
"""
