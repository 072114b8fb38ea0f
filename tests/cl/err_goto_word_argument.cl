$$ A word where GOTO expects its third number.
GOTO/1,2,X
