def ripple_outputs():
    return []
