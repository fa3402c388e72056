import csv, math
def taps_bil(n_in, n_out):
    r=n_in/n_out; out=[]
    for d in range(n_out):
        s=max((d+0.5)*r-0.5,0.0); i0=min(int(math.floor(s)),n_in-1); i1=min(i0+1,n_in-1)
        l=0.0 if i1==i0 else s-i0
        out.append((1-l)**2+l**2 if l>0 else 1.0)
    return out
def taps_area(n_in,n_out):
    r=n_in/n_out; out=[]
    for d in range(n_out):
        a,b=d*r,(d+1)*r; t=0
        for i in range(int(math.floor(a)), min(int(math.ceil(b)),n_in)):
            o=max(min(b,i+1)-max(a,i),0)/r; t+=o*o
        out.append(t)
    return out
def size(w,h,S=240,L=400):
    sc=min(S/min(w,h), L/max(w,h)); return max(1,round(w*sc)), max(1,round(h*sc))
rows=list(csv.DictReader(open('crates/joca-camera/data/sensors.csv')))
seen=set(); res=[]
for r in rows:
    if r['sensor'] in seen: continue
    seen.add(r['sensor'])
    w,h=int(r['res_x']),int(r['res_y']); p=float(r['pixel_um'])
    W,H=size(w,h)
    fb=(sum(taps_bil(w,W))/W)*(sum(taps_bil(h,H))/H)
    fa=(sum(taps_area(w,W))/W)*(sum(taps_area(h,H))/H)
    # SNR of a mid-grey (I0 = 60 DN at E0,G0) green pixel at E0,G0, noise x1 and x20
    I=60*(p/3.75)**2
    snr=lambda f,n: I/math.sqrt(f*n*(0.12*I+0.91))
    res.append((p,r['sensor'],w,h,W,H,fb,fa,snr(fb,1),snr(fa,1),snr(fb,20),snr(fa,20)))
res.sort()
print("| sensor | pitch µm | grid | input | Σw² bilinear | Σw² area | SNR bilinear ×1 | SNR area ×1 | SNR bilinear ×20 | SNR area ×20 |")
print("|---|---|---|---|---|---|---|---|---|---|")
for p,n,w,h,W,H,fb,fa,a,b,c,d in res:
    print(f"| {n} | {p} | {w}×{h} | {W}×{H} | {fb:.3f} | {fa:.4f} | {a:.1f} | {b:.1f} | {c:.1f} | {d:.1f} |")
