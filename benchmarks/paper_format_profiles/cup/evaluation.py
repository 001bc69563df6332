import numpy as np


def is_successful(agent_pos_list, agent_rotm_list, agent_obj_contact_number_list,
                  agent_ground_contact_list, obj_center, obj_bbox):
    # Cup: water droplets must end inside the cup (inside the bounding box in x/y,
    # centre below the rim) and must not touch the ground. Success if >= 60 % retained.
    droplet_radius = 0.004
    n = len(agent_pos_list)
    if n == 0:
        return 0.0, False, []
    pos = np.asarray(agent_pos_list, dtype=float).reshape(n, 3)
    center = np.asarray(obj_center, dtype=float).reshape(3)
    half = 0.5 * np.asarray(obj_bbox, dtype=float).reshape(3)
    ground = np.asarray(agent_ground_contact_list, dtype=bool).reshape(n)

    top = center[2] + half[2]
    in_x = np.abs(pos[:, 0] - center[0]) <= half[0]
    in_y = np.abs(pos[:, 1] - center[1]) <= half[1]
    below_rim = pos[:, 2] < top
    off_floor = pos[:, 2] > droplet_radius * 1.5
    ok = in_x & in_y & below_rim & off_floor & (~ground)

    fraction = float(np.count_nonzero(ok)) / float(n)
    judgement = bool(fraction >= 0.6)
    successful_agents = [int(i) for i in np.nonzero(ok)[0]]
    return fraction, judgement, successful_agents
