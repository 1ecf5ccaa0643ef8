# Stage "gamma": rules arrive with its issue.


def gamma_outputs():
    return []
