# Stage "control": rules arrive with its issue.


def control_outputs():
    return []
