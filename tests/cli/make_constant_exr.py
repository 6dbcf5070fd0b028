#!/usr/bin/env python3
"""Writes a constant-radiance OpenEXR map (uncompressed scanlines, FLOAT B, G, R) for tests that
need a uniformly lit world, e.g. a flat field for `glint calibrate vignetting`.
Usage: make_constant_exr.py OUT.exr WIDTH HEIGHT VALUE"""
import struct
import sys


# One header attribute: name, type, size, value (OpenEXR file layout).
def attr(name, typ, data): return name.encode()+b'\0'+typ.encode()+b'\0'+struct.pack('<i',len(data))+data


def const_exr(path, w, h, value):
    chans=b''.join(c.encode()+b'\0'+struct.pack('<iB3xii',2,0,1,1) for c in 'BGR')+b'\0'
    hdr=b''.join([attr('channels','chlist',chans), attr('compression','compression',b'\0'),
        attr('dataWindow','box2i',struct.pack('<iiii',0,0,w-1,h-1)), attr('displayWindow','box2i',struct.pack('<iiii',0,0,w-1,h-1)),
        attr('lineOrder','lineOrder',b'\0'), attr('pixelAspectRatio','float',struct.pack('<f',1)),
        attr('screenWindowCenter','v2f',struct.pack('<ff',0,0)), attr('screenWindowWidth','float',struct.pack('<f',1))])+b'\0'
    head=struct.pack('<ii',20000630,2)+hdr
    line=struct.pack('<f',value)*(3*w)
    start=len(head)+8*h
    offsets=b''.join(struct.pack('<Q',start+y*(8+len(line))) for y in range(h))
    body=b''.join(struct.pack('<ii',y,len(line))+line for y in range(h))
    open(path,'wb').write(head+offsets+body)


const_exr(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4]))
