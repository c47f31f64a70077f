"""RL training, evaluation and policy_node (filled by the policy issue)."""
