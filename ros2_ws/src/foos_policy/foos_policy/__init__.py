"""foos_policy: the paper's task as a gymnasium env on foos_sim, SAC/TQC training, honest evaluation, and
policy_node (`/ball/state` and `/joint_states` in, `/<team>/rods/command` out)."""
