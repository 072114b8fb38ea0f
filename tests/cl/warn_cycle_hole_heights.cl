$$ RETURN,0 (CATIA, Creo): back to the height before the cycle, measured at the first hole; a
$$ hole at another height gets a warning.
RAPID
GOTO/0,0,25
CYCLE/DRILL,DEPTH,4.6,MMPR,0.08,CLEAR,2.0,RETURN,0.0
GOTO/0,0,0
GOTO/10,0,-5
CYCLE/OFF
