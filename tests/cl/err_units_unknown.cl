$$ A unit the reader does not know.
UNITS/FEET
GOTO/1,2,3
