$$ $$ inside a quoted text is not a comment; a $$ after a statement is.
SYN/'TLAXIS','$$*TLAXIS'
PPRINT/'cost $$ 5'
GOTO/1.9949,0.1148,1.4399 $$ 1.9949,0.0707,1.3611
