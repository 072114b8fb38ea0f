$$ Two arguments separated by blanks only (the CAMWorks CYCLE bug, here in a GOTO).
GOTO/1,2 3
