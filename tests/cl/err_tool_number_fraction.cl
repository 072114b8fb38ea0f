$$ A tool number that is not a whole number.
LOAD/TOOL,1.5
