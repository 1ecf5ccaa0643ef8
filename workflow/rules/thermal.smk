# Stage "thermal": rules arrive with its issue.


def thermal_outputs():
    return []
