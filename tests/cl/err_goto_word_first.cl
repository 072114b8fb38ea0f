$$ A letter O typed for a zero: in CL data a word where a number belongs is an error.
FEDRAT/100
GOTO/0,0,0
GOTO/1O.5,2,3
GOTO/2,0,0
