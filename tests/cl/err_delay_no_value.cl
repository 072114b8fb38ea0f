$$ A dwell in revolutions without the number of revolutions.
DELAY/REV
