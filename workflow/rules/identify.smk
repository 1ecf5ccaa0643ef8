# Stage "identify": rules arrive with its issue.


def identify_outputs():
    return []
