$$ A second slash inside the arguments.
GOTO/1,2/3
