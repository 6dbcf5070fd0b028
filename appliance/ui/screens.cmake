# (placeholder until the screens library lands)
