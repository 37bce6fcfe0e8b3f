var n = 0
while iterations < 2
  G1 X{iterations*10} F600
if move.axes[0].homed
  G0 X0
else
  abort "not homed"
T-1
G38.2 Z-20
