# Latency benchmark: 64 motes on one base station (a pseudo-terminal that the
# benchmark writes real mote frames into), each through the tqt chain (glove_tqt.pat).
# Written by benchmarks.latency.mote_patch_text(); the benchmark sets base.device, base.rate and
# every gN/out.port.
#
# Sample tag: the benchmark puts 1548 + (k mod 1000) into the gyro x count of frame k;
# tapN/tagN map it to 0..99.9 in osc_out's spread field, so each OSC message names its frame.

node base mote ids=[1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31, 32, 33, 34, 35, 36, 37, 38, 39, 40, 41, 42, 43, 44, 45, 46, 47, 48, 49, 50, 51, 52, 53, 54, 55, 56, 57, 58, 59, 60, 61, 62, 63, 64] rate=1000
node tap1 unpack f
node tag1 map 1548 2548 0 100
node g1   glove_tqt.pat id=1 port=9000 rate=1000
node tap2 unpack f
node tag2 map 1548 2548 0 100
node g2   glove_tqt.pat id=2 port=9000 rate=1000
node tap3 unpack f
node tag3 map 1548 2548 0 100
node g3   glove_tqt.pat id=3 port=9000 rate=1000
node tap4 unpack f
node tag4 map 1548 2548 0 100
node g4   glove_tqt.pat id=4 port=9000 rate=1000
node tap5 unpack f
node tag5 map 1548 2548 0 100
node g5   glove_tqt.pat id=5 port=9000 rate=1000
node tap6 unpack f
node tag6 map 1548 2548 0 100
node g6   glove_tqt.pat id=6 port=9000 rate=1000
node tap7 unpack f
node tag7 map 1548 2548 0 100
node g7   glove_tqt.pat id=7 port=9000 rate=1000
node tap8 unpack f
node tag8 map 1548 2548 0 100
node g8   glove_tqt.pat id=8 port=9000 rate=1000
node tap9 unpack f
node tag9 map 1548 2548 0 100
node g9   glove_tqt.pat id=9 port=9000 rate=1000
node tap10 unpack f
node tag10 map 1548 2548 0 100
node g10   glove_tqt.pat id=10 port=9000 rate=1000
node tap11 unpack f
node tag11 map 1548 2548 0 100
node g11   glove_tqt.pat id=11 port=9000 rate=1000
node tap12 unpack f
node tag12 map 1548 2548 0 100
node g12   glove_tqt.pat id=12 port=9000 rate=1000
node tap13 unpack f
node tag13 map 1548 2548 0 100
node g13   glove_tqt.pat id=13 port=9000 rate=1000
node tap14 unpack f
node tag14 map 1548 2548 0 100
node g14   glove_tqt.pat id=14 port=9000 rate=1000
node tap15 unpack f
node tag15 map 1548 2548 0 100
node g15   glove_tqt.pat id=15 port=9000 rate=1000
node tap16 unpack f
node tag16 map 1548 2548 0 100
node g16   glove_tqt.pat id=16 port=9000 rate=1000
node tap17 unpack f
node tag17 map 1548 2548 0 100
node g17   glove_tqt.pat id=17 port=9000 rate=1000
node tap18 unpack f
node tag18 map 1548 2548 0 100
node g18   glove_tqt.pat id=18 port=9000 rate=1000
node tap19 unpack f
node tag19 map 1548 2548 0 100
node g19   glove_tqt.pat id=19 port=9000 rate=1000
node tap20 unpack f
node tag20 map 1548 2548 0 100
node g20   glove_tqt.pat id=20 port=9000 rate=1000
node tap21 unpack f
node tag21 map 1548 2548 0 100
node g21   glove_tqt.pat id=21 port=9000 rate=1000
node tap22 unpack f
node tag22 map 1548 2548 0 100
node g22   glove_tqt.pat id=22 port=9000 rate=1000
node tap23 unpack f
node tag23 map 1548 2548 0 100
node g23   glove_tqt.pat id=23 port=9000 rate=1000
node tap24 unpack f
node tag24 map 1548 2548 0 100
node g24   glove_tqt.pat id=24 port=9000 rate=1000
node tap25 unpack f
node tag25 map 1548 2548 0 100
node g25   glove_tqt.pat id=25 port=9000 rate=1000
node tap26 unpack f
node tag26 map 1548 2548 0 100
node g26   glove_tqt.pat id=26 port=9000 rate=1000
node tap27 unpack f
node tag27 map 1548 2548 0 100
node g27   glove_tqt.pat id=27 port=9000 rate=1000
node tap28 unpack f
node tag28 map 1548 2548 0 100
node g28   glove_tqt.pat id=28 port=9000 rate=1000
node tap29 unpack f
node tag29 map 1548 2548 0 100
node g29   glove_tqt.pat id=29 port=9000 rate=1000
node tap30 unpack f
node tag30 map 1548 2548 0 100
node g30   glove_tqt.pat id=30 port=9000 rate=1000
node tap31 unpack f
node tag31 map 1548 2548 0 100
node g31   glove_tqt.pat id=31 port=9000 rate=1000
node tap32 unpack f
node tag32 map 1548 2548 0 100
node g32   glove_tqt.pat id=32 port=9000 rate=1000
node tap33 unpack f
node tag33 map 1548 2548 0 100
node g33   glove_tqt.pat id=33 port=9000 rate=1000
node tap34 unpack f
node tag34 map 1548 2548 0 100
node g34   glove_tqt.pat id=34 port=9000 rate=1000
node tap35 unpack f
node tag35 map 1548 2548 0 100
node g35   glove_tqt.pat id=35 port=9000 rate=1000
node tap36 unpack f
node tag36 map 1548 2548 0 100
node g36   glove_tqt.pat id=36 port=9000 rate=1000
node tap37 unpack f
node tag37 map 1548 2548 0 100
node g37   glove_tqt.pat id=37 port=9000 rate=1000
node tap38 unpack f
node tag38 map 1548 2548 0 100
node g38   glove_tqt.pat id=38 port=9000 rate=1000
node tap39 unpack f
node tag39 map 1548 2548 0 100
node g39   glove_tqt.pat id=39 port=9000 rate=1000
node tap40 unpack f
node tag40 map 1548 2548 0 100
node g40   glove_tqt.pat id=40 port=9000 rate=1000
node tap41 unpack f
node tag41 map 1548 2548 0 100
node g41   glove_tqt.pat id=41 port=9000 rate=1000
node tap42 unpack f
node tag42 map 1548 2548 0 100
node g42   glove_tqt.pat id=42 port=9000 rate=1000
node tap43 unpack f
node tag43 map 1548 2548 0 100
node g43   glove_tqt.pat id=43 port=9000 rate=1000
node tap44 unpack f
node tag44 map 1548 2548 0 100
node g44   glove_tqt.pat id=44 port=9000 rate=1000
node tap45 unpack f
node tag45 map 1548 2548 0 100
node g45   glove_tqt.pat id=45 port=9000 rate=1000
node tap46 unpack f
node tag46 map 1548 2548 0 100
node g46   glove_tqt.pat id=46 port=9000 rate=1000
node tap47 unpack f
node tag47 map 1548 2548 0 100
node g47   glove_tqt.pat id=47 port=9000 rate=1000
node tap48 unpack f
node tag48 map 1548 2548 0 100
node g48   glove_tqt.pat id=48 port=9000 rate=1000
node tap49 unpack f
node tag49 map 1548 2548 0 100
node g49   glove_tqt.pat id=49 port=9000 rate=1000
node tap50 unpack f
node tag50 map 1548 2548 0 100
node g50   glove_tqt.pat id=50 port=9000 rate=1000
node tap51 unpack f
node tag51 map 1548 2548 0 100
node g51   glove_tqt.pat id=51 port=9000 rate=1000
node tap52 unpack f
node tag52 map 1548 2548 0 100
node g52   glove_tqt.pat id=52 port=9000 rate=1000
node tap53 unpack f
node tag53 map 1548 2548 0 100
node g53   glove_tqt.pat id=53 port=9000 rate=1000
node tap54 unpack f
node tag54 map 1548 2548 0 100
node g54   glove_tqt.pat id=54 port=9000 rate=1000
node tap55 unpack f
node tag55 map 1548 2548 0 100
node g55   glove_tqt.pat id=55 port=9000 rate=1000
node tap56 unpack f
node tag56 map 1548 2548 0 100
node g56   glove_tqt.pat id=56 port=9000 rate=1000
node tap57 unpack f
node tag57 map 1548 2548 0 100
node g57   glove_tqt.pat id=57 port=9000 rate=1000
node tap58 unpack f
node tag58 map 1548 2548 0 100
node g58   glove_tqt.pat id=58 port=9000 rate=1000
node tap59 unpack f
node tag59 map 1548 2548 0 100
node g59   glove_tqt.pat id=59 port=9000 rate=1000
node tap60 unpack f
node tag60 map 1548 2548 0 100
node g60   glove_tqt.pat id=60 port=9000 rate=1000
node tap61 unpack f
node tag61 map 1548 2548 0 100
node g61   glove_tqt.pat id=61 port=9000 rate=1000
node tap62 unpack f
node tag62 map 1548 2548 0 100
node g62   glove_tqt.pat id=62 port=9000 rate=1000
node tap63 unpack f
node tag63 map 1548 2548 0 100
node g63   glove_tqt.pat id=63 port=9000 rate=1000
node tap64 unpack f
node tag64 map 1548 2548 0 100
node g64   glove_tqt.pat id=64 port=9000 rate=1000

base.m1 -> tap1 -> tag1 -> g1.spread
base.m1 -> g1.adc
base.m2 -> tap2 -> tag2 -> g2.spread
base.m2 -> g2.adc
base.m3 -> tap3 -> tag3 -> g3.spread
base.m3 -> g3.adc
base.m4 -> tap4 -> tag4 -> g4.spread
base.m4 -> g4.adc
base.m5 -> tap5 -> tag5 -> g5.spread
base.m5 -> g5.adc
base.m6 -> tap6 -> tag6 -> g6.spread
base.m6 -> g6.adc
base.m7 -> tap7 -> tag7 -> g7.spread
base.m7 -> g7.adc
base.m8 -> tap8 -> tag8 -> g8.spread
base.m8 -> g8.adc
base.m9 -> tap9 -> tag9 -> g9.spread
base.m9 -> g9.adc
base.m10 -> tap10 -> tag10 -> g10.spread
base.m10 -> g10.adc
base.m11 -> tap11 -> tag11 -> g11.spread
base.m11 -> g11.adc
base.m12 -> tap12 -> tag12 -> g12.spread
base.m12 -> g12.adc
base.m13 -> tap13 -> tag13 -> g13.spread
base.m13 -> g13.adc
base.m14 -> tap14 -> tag14 -> g14.spread
base.m14 -> g14.adc
base.m15 -> tap15 -> tag15 -> g15.spread
base.m15 -> g15.adc
base.m16 -> tap16 -> tag16 -> g16.spread
base.m16 -> g16.adc
base.m17 -> tap17 -> tag17 -> g17.spread
base.m17 -> g17.adc
base.m18 -> tap18 -> tag18 -> g18.spread
base.m18 -> g18.adc
base.m19 -> tap19 -> tag19 -> g19.spread
base.m19 -> g19.adc
base.m20 -> tap20 -> tag20 -> g20.spread
base.m20 -> g20.adc
base.m21 -> tap21 -> tag21 -> g21.spread
base.m21 -> g21.adc
base.m22 -> tap22 -> tag22 -> g22.spread
base.m22 -> g22.adc
base.m23 -> tap23 -> tag23 -> g23.spread
base.m23 -> g23.adc
base.m24 -> tap24 -> tag24 -> g24.spread
base.m24 -> g24.adc
base.m25 -> tap25 -> tag25 -> g25.spread
base.m25 -> g25.adc
base.m26 -> tap26 -> tag26 -> g26.spread
base.m26 -> g26.adc
base.m27 -> tap27 -> tag27 -> g27.spread
base.m27 -> g27.adc
base.m28 -> tap28 -> tag28 -> g28.spread
base.m28 -> g28.adc
base.m29 -> tap29 -> tag29 -> g29.spread
base.m29 -> g29.adc
base.m30 -> tap30 -> tag30 -> g30.spread
base.m30 -> g30.adc
base.m31 -> tap31 -> tag31 -> g31.spread
base.m31 -> g31.adc
base.m32 -> tap32 -> tag32 -> g32.spread
base.m32 -> g32.adc
base.m33 -> tap33 -> tag33 -> g33.spread
base.m33 -> g33.adc
base.m34 -> tap34 -> tag34 -> g34.spread
base.m34 -> g34.adc
base.m35 -> tap35 -> tag35 -> g35.spread
base.m35 -> g35.adc
base.m36 -> tap36 -> tag36 -> g36.spread
base.m36 -> g36.adc
base.m37 -> tap37 -> tag37 -> g37.spread
base.m37 -> g37.adc
base.m38 -> tap38 -> tag38 -> g38.spread
base.m38 -> g38.adc
base.m39 -> tap39 -> tag39 -> g39.spread
base.m39 -> g39.adc
base.m40 -> tap40 -> tag40 -> g40.spread
base.m40 -> g40.adc
base.m41 -> tap41 -> tag41 -> g41.spread
base.m41 -> g41.adc
base.m42 -> tap42 -> tag42 -> g42.spread
base.m42 -> g42.adc
base.m43 -> tap43 -> tag43 -> g43.spread
base.m43 -> g43.adc
base.m44 -> tap44 -> tag44 -> g44.spread
base.m44 -> g44.adc
base.m45 -> tap45 -> tag45 -> g45.spread
base.m45 -> g45.adc
base.m46 -> tap46 -> tag46 -> g46.spread
base.m46 -> g46.adc
base.m47 -> tap47 -> tag47 -> g47.spread
base.m47 -> g47.adc
base.m48 -> tap48 -> tag48 -> g48.spread
base.m48 -> g48.adc
base.m49 -> tap49 -> tag49 -> g49.spread
base.m49 -> g49.adc
base.m50 -> tap50 -> tag50 -> g50.spread
base.m50 -> g50.adc
base.m51 -> tap51 -> tag51 -> g51.spread
base.m51 -> g51.adc
base.m52 -> tap52 -> tag52 -> g52.spread
base.m52 -> g52.adc
base.m53 -> tap53 -> tag53 -> g53.spread
base.m53 -> g53.adc
base.m54 -> tap54 -> tag54 -> g54.spread
base.m54 -> g54.adc
base.m55 -> tap55 -> tag55 -> g55.spread
base.m55 -> g55.adc
base.m56 -> tap56 -> tag56 -> g56.spread
base.m56 -> g56.adc
base.m57 -> tap57 -> tag57 -> g57.spread
base.m57 -> g57.adc
base.m58 -> tap58 -> tag58 -> g58.spread
base.m58 -> g58.adc
base.m59 -> tap59 -> tag59 -> g59.spread
base.m59 -> g59.adc
base.m60 -> tap60 -> tag60 -> g60.spread
base.m60 -> g60.adc
base.m61 -> tap61 -> tag61 -> g61.spread
base.m61 -> g61.adc
base.m62 -> tap62 -> tag62 -> g62.spread
base.m62 -> g62.adc
base.m63 -> tap63 -> tag63 -> g63.spread
base.m63 -> g63.adc
base.m64 -> tap64 -> tag64 -> g64.spread
base.m64 -> g64.adc
