# (placeholder until the kiosk library lands)
