// STREAM-style triad a = b + s*c and copy on one core, best of 10, in a working set of
// the given size (bytes over the three arrays).
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
static double now(void){struct timespec t;clock_gettime(CLOCK_MONOTONIC,&t);return t.tv_sec+1e-9*t.tv_nsec;}
int main(int argc,char**argv){
  size_t bytes = argc>1? strtoull(argv[1],0,10) : 3ull<<28;
  size_t n = bytes/3/8; int reps = argc>2? atoi(argv[2]) : 10;
  double *a=aligned_alloc(64,n*8),*b=aligned_alloc(64,n*8),*c=aligned_alloc(64,n*8);
  for(size_t i=0;i<n;i++){a[i]=1;b[i]=2;c[i]=0.5;}
  double best_t=1e30,best_c=1e30; size_t inner = (1ull<<27)/n + 1;
  for(int r=0;r<reps;r++){
    double t0=now();
    for(size_t k=0;k<inner;k++){ for(size_t i=0;i<n;i++) a[i]=b[i]+3.0*c[i]; __asm__ volatile(""::"r"(a):"memory"); }
    double t1=now();
    for(size_t k=0;k<inner;k++){ for(size_t i=0;i<n;i++) c[i]=a[i]; __asm__ volatile(""::"r"(c):"memory"); }
    double t2=now();
    if(t1-t0<best_t)best_t=t1-t0; if(t2-t1<best_c)best_c=t2-t1;
  }
  // triad moves 3 x 8 bytes an element as STREAM counts it (no write-allocate)
  printf("working set %.1f MB: triad %.1f GB/s, copy %.1f GB/s (check %g)\n", bytes/1e6,
    24.0*n*inner/best_t/1e9, 16.0*n*inner/best_c/1e9, a[n/2]+c[n/3]);
  return 0;
}
