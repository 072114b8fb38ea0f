$$ Statements after FINI.
GOTO/1,2,3
FINI
GOTO/4,5,6
