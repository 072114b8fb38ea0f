$$ A number too large for a double.
GOTO/1E999,2,3
