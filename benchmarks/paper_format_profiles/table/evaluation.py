import numpy as np


def is_successful(agent_pos_list, agent_rotm_list, agent_obj_contact_number_list,
                  agent_ground_contact_list, obj_center, obj_bbox):
    # Table: boxes must rest on the raised top: centre within the footprint, near the top of
    # the bounding box (not fallen under it), at least 0.30 m above the ground, touching the
    # object and not the ground. Success if at least 75 % of the boxes are on the top.
    below_top_tolerance = 0.08
    above_top_tolerance = 0.30
    min_height = 0.30
    n = len(agent_pos_list)
    if n == 0:
        return 0.0, False, []
    pos = np.asarray(agent_pos_list, dtype=float).reshape(n, 3)
    center = np.asarray(obj_center, dtype=float).reshape(3)
    half = 0.5 * np.asarray(obj_bbox, dtype=float).reshape(3)
    top = center[2] + half[2]
    contacts = np.asarray(agent_obj_contact_number_list, dtype=float).reshape(n)
    ground = np.asarray(agent_ground_contact_list, dtype=bool).reshape(n)

    in_x = np.abs(pos[:, 0] - center[0]) <= half[0]
    in_y = np.abs(pos[:, 1] - center[1]) <= half[1]
    at_top = (pos[:, 2] >= top - below_top_tolerance) & (pos[:, 2] <= top + above_top_tolerance)
    raised = pos[:, 2] >= min_height
    ok = in_x & in_y & at_top & raised & (contacts > 0) & (~ground)

    fraction = float(np.count_nonzero(ok)) / float(n)
    judgement = bool(fraction >= 0.75)
    successful_agents = [int(i) for i in np.nonzero(ok)[0]]
    return fraction, judgement, successful_agents
