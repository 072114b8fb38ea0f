$$ A CYCLE that starts with a number instead of its kind.
CYCLE/5.0,MMPM,100
CYCLE/OFF
