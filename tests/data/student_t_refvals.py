from mpmath import mp, hyp2f1, besselk, quad, gamma, sqrt, pi, inf, mpf, exp
mp.dps = 30
print("// 2F1(1/2, b; 3/2; z)")
for b in [1.1, 1.5, 2.5, 3.5, 7.0, 29.5, 30.5]:
    for z in [-1e-3, -0.3, -0.9, -5.0, -100.0, -1e4]:
        print(f"    ({b!r}, {z!r}, {mp.nstr(hyp2f1(0.5, b, 1.5, z), 20)}),")
print("// K0, K1")
for x in [1e-6, 1e-3, 0.1, 0.5, 1.0, 1.99, 2.01, 3.0, 7.0, 20.0, 80.0]:
    print(f"    ({x!r}, {mp.nstr(besselk(0,x),20)}, {mp.nstr(besselk(1,x),20)}),")
print("// Student-T Lambda(mu, gamma), alpha=1, mu = cot(theta): (1/mu) int_mu^inf (q - mu) P2(q) dq")
for g in [1.6, 2.0, 3.0, 10.0]:
    C = (mpf(g)-1)**g * gamma(mpf(g)-0.5)/(sqrt(pi)*gamma(g))
    P2 = lambda q: C*((g-1)+q*q)**(0.5-g)
    for mu in [0.05, 0.5, 1.0, 3.0, 20.0]:
        # q = mu + e^x: the integrand's q^(1 - 2 gamma) tail defeats a plain [mu, inf] quad.
        L = quad(lambda x: exp(2*x)*P2(mu+exp(x)), [-inf, -5, 0, 5, 20, 60, 200])/mu
        print(f"    ({g!r}, {mu!r}, {mp.nstr(L,20)}),")
