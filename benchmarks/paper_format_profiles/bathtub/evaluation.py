import numpy as np


def is_successful(agent_pos_list, agent_rotm_list, agent_obj_contact_number_list,
                  agent_ground_contact_list, obj_center, obj_bbox):
    # Bathtub: the small lying body must end inside the tub: centre within the footprint,
    # at least 0.10 m below the rim and in the lower half of the object's height, long axis
    # (local x) near horizontal, touching the tub, not touching the ground.
    xy_margin = 0.02
    min_depth = 0.10
    max_long_axis_z = 0.6  # |sin| of ~37 deg tilt of the long axis
    n = len(agent_pos_list)
    if n == 0:
        return 0.0, False, []
    center = np.asarray(obj_center, dtype=float).reshape(3)
    half = 0.5 * np.asarray(obj_bbox, dtype=float).reshape(3)
    top = center[2] + half[2]

    weights = np.array([0.25, 0.25, 0.2, 0.15, 0.15])
    scores = np.zeros(n)
    ok = np.zeros(n, dtype=bool)
    for i in range(n):
        p = np.asarray(agent_pos_list[i], dtype=float).reshape(3)
        rotm = np.asarray(agent_rotm_list[i], dtype=float).reshape(3, 3)
        inside_xy = (abs(p[0] - center[0]) <= max(half[0] - xy_margin, 0.0)) and \
                    (abs(p[1] - center[1]) <= max(half[1] - xy_margin, 0.0))
        sunk = ((top - p[2]) >= min_depth) and (p[2] <= center[2])
        lying = abs(rotm[2, 0]) <= max_long_axis_z
        touching = int(agent_obj_contact_number_list[i]) > 0
        off_ground = not bool(agent_ground_contact_list[i])
        crit = np.array([inside_xy, sunk, lying, touching, off_ground], dtype=float)
        ok[i] = bool(np.all(crit > 0.5))
        scores[i] = float(np.dot(weights, crit))

    successful_agents = [int(i) for i in np.nonzero(ok)[0]]
    judgement = bool(len(successful_agents) == n)
    score = float(np.mean(scores))
    return score, judgement, successful_agents
