# (placeholder until the config library lands)
