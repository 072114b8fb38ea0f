$$ A dwell cannot be negative.
GOTO/0,0,0
DELAY/-1
