# Cost benchmark: 64 motes on one base station (a pseudo-terminal that the
# benchmark writes real mote frames into), each through the tqt chain (glove_tqt.pat), untagged: what a glove-sample costs, nothing added.
# Written by benchmarks.latency.mote_patch_text(); the benchmark sets base.device, base.rate and
# every gN/out.port.  No sample tag: the outputs are counted, not matched.

node base mote ids=[1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31, 32, 33, 34, 35, 36, 37, 38, 39, 40, 41, 42, 43, 44, 45, 46, 47, 48, 49, 50, 51, 52, 53, 54, 55, 56, 57, 58, 59, 60, 61, 62, 63, 64] rate=1000
node g1   glove_tqt.pat id=1 port=9000 rate=1000
node g2   glove_tqt.pat id=2 port=9000 rate=1000
node g3   glove_tqt.pat id=3 port=9000 rate=1000
node g4   glove_tqt.pat id=4 port=9000 rate=1000
node g5   glove_tqt.pat id=5 port=9000 rate=1000
node g6   glove_tqt.pat id=6 port=9000 rate=1000
node g7   glove_tqt.pat id=7 port=9000 rate=1000
node g8   glove_tqt.pat id=8 port=9000 rate=1000
node g9   glove_tqt.pat id=9 port=9000 rate=1000
node g10   glove_tqt.pat id=10 port=9000 rate=1000
node g11   glove_tqt.pat id=11 port=9000 rate=1000
node g12   glove_tqt.pat id=12 port=9000 rate=1000
node g13   glove_tqt.pat id=13 port=9000 rate=1000
node g14   glove_tqt.pat id=14 port=9000 rate=1000
node g15   glove_tqt.pat id=15 port=9000 rate=1000
node g16   glove_tqt.pat id=16 port=9000 rate=1000
node g17   glove_tqt.pat id=17 port=9000 rate=1000
node g18   glove_tqt.pat id=18 port=9000 rate=1000
node g19   glove_tqt.pat id=19 port=9000 rate=1000
node g20   glove_tqt.pat id=20 port=9000 rate=1000
node g21   glove_tqt.pat id=21 port=9000 rate=1000
node g22   glove_tqt.pat id=22 port=9000 rate=1000
node g23   glove_tqt.pat id=23 port=9000 rate=1000
node g24   glove_tqt.pat id=24 port=9000 rate=1000
node g25   glove_tqt.pat id=25 port=9000 rate=1000
node g26   glove_tqt.pat id=26 port=9000 rate=1000
node g27   glove_tqt.pat id=27 port=9000 rate=1000
node g28   glove_tqt.pat id=28 port=9000 rate=1000
node g29   glove_tqt.pat id=29 port=9000 rate=1000
node g30   glove_tqt.pat id=30 port=9000 rate=1000
node g31   glove_tqt.pat id=31 port=9000 rate=1000
node g32   glove_tqt.pat id=32 port=9000 rate=1000
node g33   glove_tqt.pat id=33 port=9000 rate=1000
node g34   glove_tqt.pat id=34 port=9000 rate=1000
node g35   glove_tqt.pat id=35 port=9000 rate=1000
node g36   glove_tqt.pat id=36 port=9000 rate=1000
node g37   glove_tqt.pat id=37 port=9000 rate=1000
node g38   glove_tqt.pat id=38 port=9000 rate=1000
node g39   glove_tqt.pat id=39 port=9000 rate=1000
node g40   glove_tqt.pat id=40 port=9000 rate=1000
node g41   glove_tqt.pat id=41 port=9000 rate=1000
node g42   glove_tqt.pat id=42 port=9000 rate=1000
node g43   glove_tqt.pat id=43 port=9000 rate=1000
node g44   glove_tqt.pat id=44 port=9000 rate=1000
node g45   glove_tqt.pat id=45 port=9000 rate=1000
node g46   glove_tqt.pat id=46 port=9000 rate=1000
node g47   glove_tqt.pat id=47 port=9000 rate=1000
node g48   glove_tqt.pat id=48 port=9000 rate=1000
node g49   glove_tqt.pat id=49 port=9000 rate=1000
node g50   glove_tqt.pat id=50 port=9000 rate=1000
node g51   glove_tqt.pat id=51 port=9000 rate=1000
node g52   glove_tqt.pat id=52 port=9000 rate=1000
node g53   glove_tqt.pat id=53 port=9000 rate=1000
node g54   glove_tqt.pat id=54 port=9000 rate=1000
node g55   glove_tqt.pat id=55 port=9000 rate=1000
node g56   glove_tqt.pat id=56 port=9000 rate=1000
node g57   glove_tqt.pat id=57 port=9000 rate=1000
node g58   glove_tqt.pat id=58 port=9000 rate=1000
node g59   glove_tqt.pat id=59 port=9000 rate=1000
node g60   glove_tqt.pat id=60 port=9000 rate=1000
node g61   glove_tqt.pat id=61 port=9000 rate=1000
node g62   glove_tqt.pat id=62 port=9000 rate=1000
node g63   glove_tqt.pat id=63 port=9000 rate=1000
node g64   glove_tqt.pat id=64 port=9000 rate=1000

base.m1 -> g1.adc
base.m2 -> g2.adc
base.m3 -> g3.adc
base.m4 -> g4.adc
base.m5 -> g5.adc
base.m6 -> g6.adc
base.m7 -> g7.adc
base.m8 -> g8.adc
base.m9 -> g9.adc
base.m10 -> g10.adc
base.m11 -> g11.adc
base.m12 -> g12.adc
base.m13 -> g13.adc
base.m14 -> g14.adc
base.m15 -> g15.adc
base.m16 -> g16.adc
base.m17 -> g17.adc
base.m18 -> g18.adc
base.m19 -> g19.adc
base.m20 -> g20.adc
base.m21 -> g21.adc
base.m22 -> g22.adc
base.m23 -> g23.adc
base.m24 -> g24.adc
base.m25 -> g25.adc
base.m26 -> g26.adc
base.m27 -> g27.adc
base.m28 -> g28.adc
base.m29 -> g29.adc
base.m30 -> g30.adc
base.m31 -> g31.adc
base.m32 -> g32.adc
base.m33 -> g33.adc
base.m34 -> g34.adc
base.m35 -> g35.adc
base.m36 -> g36.adc
base.m37 -> g37.adc
base.m38 -> g38.adc
base.m39 -> g39.adc
base.m40 -> g40.adc
base.m41 -> g41.adc
base.m42 -> g42.adc
base.m43 -> g43.adc
base.m44 -> g44.adc
base.m45 -> g45.adc
base.m46 -> g46.adc
base.m47 -> g47.adc
base.m48 -> g48.adc
base.m49 -> g49.adc
base.m50 -> g50.adc
base.m51 -> g51.adc
base.m52 -> g52.adc
base.m53 -> g53.adc
base.m54 -> g54.adc
base.m55 -> g55.adc
base.m56 -> g56.adc
base.m57 -> g57.adc
base.m58 -> g58.adc
base.m59 -> g59.adc
base.m60 -> g60.adc
base.m61 -> g61.adc
base.m62 -> g62.adc
base.m63 -> g63.adc
base.m64 -> g64.adc
