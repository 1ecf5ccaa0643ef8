# Stage "report": rules arrive with its issue.


def report_outputs():
    return []
