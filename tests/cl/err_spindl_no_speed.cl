$$ A spindle start with a direction and no speed (and none before).
SPINDL/CLW
