$$ Hand-written APT in lower case.
partno lower case part
units/mm
cutter/10,0
loadtl/1
spindl/rpm,1000,clw
fedrat/100,mmpm
rapid
goto/-5,5,10
goto/-5,5,0,0,0,1
goto/-5,0,0
circle/0,0,0,0,0,1,5
goto/5,0,0
coolnt/off
fini
