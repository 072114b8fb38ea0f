$$ The units change in the middle of the file.
UNITS/MM
GOTO/1,2,3
UNITS/INCHES
GOTO/1,2,3
