# Stage "powerloss": rules arrive with its issue.


def powerloss_outputs():
    return []
