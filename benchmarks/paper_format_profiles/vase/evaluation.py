import numpy as np


def is_successful(agent_pos_list, agent_rotm_list, agent_obj_contact_number_list,
                  agent_ground_contact_list, obj_center, obj_bbox):
    # Vase: the flower stem (cylinder, length 0.35 m, axis = local z) must stand inside the
    # vase: lower end inside the footprint and >= 0.10 m below the rim, axis within ~50 deg of
    # vertical, touching the vase, not touching the ground.
    stem_half_length = 0.175
    min_depth = 0.10
    min_axis_z = 0.64  # cos(50 deg)
    n = len(agent_pos_list)
    if n == 0:
        return 0.0, False, []
    center = np.asarray(obj_center, dtype=float).reshape(3)
    half = 0.5 * np.asarray(obj_bbox, dtype=float).reshape(3)
    top = center[2] + half[2]

    scores = np.zeros(n)
    ok = np.zeros(n, dtype=bool)
    for i in range(n):
        p = np.asarray(agent_pos_list[i], dtype=float).reshape(3)
        rotm = np.asarray(agent_rotm_list[i], dtype=float).reshape(3, 3)
        axis = rotm[:, 2]
        end_a = p + stem_half_length * axis
        end_b = p - stem_half_length * axis
        lower = end_a if end_a[2] < end_b[2] else end_b
        upright = abs(axis[2])
        depth = top - lower[2]
        inside_xy = (abs(lower[0] - center[0]) <= half[0]) and (abs(lower[1] - center[1]) <= half[1])
        touching = int(agent_obj_contact_number_list[i]) > 0
        grounded = bool(agent_ground_contact_list[i])
        ok[i] = inside_xy and depth >= min_depth and upright >= min_axis_z and touching and not grounded
        if ok[i]:
            scores[i] = upright + min(1.0, depth / (2.0 * stem_half_length))

    successful_agents = [int(i) for i in np.nonzero(ok)[0]]
    judgement = bool(len(successful_agents) > 0)
    score = float(np.mean(scores))
    return score, judgement, successful_agents
