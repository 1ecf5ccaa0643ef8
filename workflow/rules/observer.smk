# Stage "observer": rules arrive with its issue.


def observer_outputs():
    return []
