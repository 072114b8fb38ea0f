$$ The file ends where a continuation line was announced.
GOTO/1,2,3 $
