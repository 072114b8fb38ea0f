$$ A table rotation by 90 with no AAXIS, BAXIS or CAXIS.
ROTABL/90,TABLE,CCLW
