"""The lighting-estimation protocol's metrics, computed by the protocol's own functions, for
tests/evaluation_metrics.rs to compare hdrflow's ImageMetrics with.

`rmse`, `si_rmse`, `angular` and `normalize` below are copied verbatim from
`stylelight/fast_rmse.py` of DiffusionLight/DiffusionLight-evaluation (MIT License, Copyright (c)
2023 Pakkapon Phongthawee), with the module globals they read (`use_debug`, `all_pixels`); the
script's own `__main__` part (argument parsing, folder walking, `hdrio`) is replaced by reading
PFM files, so that only NumPy is needed.

    python fast_rmse_peer.py PRED.pfm ALPHA.pfm GT.pfm

prints {"rmse": ..., "si_rmse": ..., "angular_error_deg": ..., "norm_rmse": ...} for the
prediction whose alpha channel is ALPHA's first channel (as the protocol's Blender renders
carry it), computed as fast_rmse.py's loop does: the mask from pred's alpha, `norm_rmse` on
`normalize(pred[..., :3])` and `normalize(gt[..., :3])` with that mask.
"""

import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pfm_common import read_pfm  # noqa: E402

use_debug = False
hdr_clip = False
all_pixels = False


# ---- verbatim from stylelight/fast_rmse.py ---------------------------------------------------
def rmse(pred, gt, mask=None):
    h = pred.shape[0]
    w = pred.shape[1]
    if mask is None:
        if all_pixels:
            mask = np.ones((h, w))
        else:
            mask = np.zeros((h, w))
            mask[pred[:,:,3]>0] = 1
    


    num_pixel = mask.sum()
    if use_debug:
        pred = np.ones_like(pred)*1e-5
    error_ = (pred[:,:,:3] - gt[:,:,:3])**2
    mask_error = np.multiply(error_, np.repeat(mask[:,:,np.newaxis],3,axis=2))
    mask_error = mask_error.sum()/num_pixel
    res = np.sqrt(mask_error)

    return res


def si_rmse(pred, gt, mask=None):
    h = pred.shape[0]
    w = pred.shape[1]
    if mask is None:
        if all_pixels:
            mask = np.ones((h, w))
        else:
            mask = np.zeros((h, w))
            mask[pred[:,:,3]>0] = 1
   
    num_pixel = mask.sum()

    if use_debug:
        pred = np.ones_like(pred)*1e-5

    x_hat_square_ = pred[:, :, :3]**2

    x_square_ = gt[:,:,:3] ** 2
    x_x_hat_ = -(2 * pred[:,:,:3] * gt[:,:,:3])
    x_hat_square_ = np.multiply(x_hat_square_, np.repeat(mask[:, :, np.newaxis], 3, axis=2))
    x_square_= np.multiply(x_square_, np.repeat(mask[:, :, np.newaxis], 3, axis=2))
    x_x_hat_ = np.multiply(x_x_hat_, np.repeat(mask[:, :, np.newaxis], 3, axis=2))

    
    a = x_hat_square_.sum()
    b = x_x_hat_.sum()
    c = x_square_.sum()
   # print(a,b,c)
   #  if 0 not in a:
    mask_error = (4*a*c-b**2)/(4*a)

    #alpha = -b/(2*a)
    #print(alpha)
    #re = rmse(alpha*pred, gt)
    #print(mask_error)

    mask_error = mask_error / num_pixel
    res = np.sqrt(mask_error)

    #print(re,res)

    return res

def angular(pred, gt, mask = None):
    h = pred.shape[0]
    w = pred.shape[1]
    if mask is None:
        mask = np.zeros((h, w))
        mask[pred[:,:,3]>0] = 1
    num_pixel = mask.sum()

    cos = np.sum(gt[:,:,:3]*pred[:,:,:3], axis=2) / (np.linalg.norm(gt[:,:,:3],axis=2) * np.linalg.norm(pred[:,:,:3],axis=2))
    cos = np.clip(cos, 0, 1)
    angular=np.nan_to_num(np.multiply(np.arccos(cos), mask))

    res=np.degrees(angular.sum()/num_pixel)

    return res

def get_mask(img):
    h,w = img.shape[:2]
    mask = np.zeros((h, w))
    mask[img[:,:,3]>0] = 1
    return mask

def normalize(x):
    # Taken form ExpandNet
    return (x - np.percentile(x,0.01)) / (np.percentile(x,99.9) - np.percentile(x,0.01))
# ---- end of the verbatim part -----------------------------------------------------------------


def main(argv):
    pred_path, alpha_path, gt_path = argv[1:4]
    rgb = read_pfm(pred_path)
    alpha = read_pfm(alpha_path)[:, :, :1]
    pred = np.concatenate([rgb, alpha], axis=2)
    gt = read_pfm(gt_path)
    np.seterr(all="ignore")
    # fast_rmse.py's loop body.
    mask = get_mask(pred.copy())
    r1 = rmse(pred, gt)
    sr1 = si_rmse(pred, gt)
    ang1 = angular(pred, gt)
    norm_pred = normalize(pred[..., :3])
    norm_gt = normalize(gt[..., :3])
    norm_r1 = rmse(norm_pred, norm_gt, mask)
    out = {"rmse": r1, "si_rmse": sr1, "angular_error_deg": ang1, "norm_rmse": norm_r1}
    print(json.dumps({k: float(v) for k, v in out.items()}))


if __name__ == "__main__":
    main(sys.argv)
