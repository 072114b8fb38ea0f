$$ An argument group opened with ( and never closed.
GOTO/1,2,(3
