import sys, csv, numpy as np
for f in sys.argv[1:]:
    rows=list(csv.DictReader(open(f)))
    w=np.array([float(r['win']) for r in rows]); l=np.array([float(r['lose']) for r in rows]); t=[int(r['timesteps']) for r in rows]
    n=200
    out=[]
    for i in range(0,len(rows),n):
        out.append(f"{t[min(i+n,len(rows))-1]//1000}k:{w[i:i+n].mean():.2f}/{l[i:i+n].mean():.2f}")
    print(f, len(rows), ' '.join(out))
