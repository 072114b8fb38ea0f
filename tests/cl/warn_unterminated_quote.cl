$$ A quoted text that is never closed.
PPRINT/'ROUGHING
GOTO/1,2,3
