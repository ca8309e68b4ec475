% Intrinsic and Extrinsic Camera Parameters
%
% This script file can be directly executed under Matlab to recover the camera intrinsic and extrinsic parameters.
% IMPORTANT: This file contains neither the structure of the calibration objects nor the image coordinates of the calibration points.
%            All those complementary variables are saved in the complete matlab data file Calib_Results_stereo.mat.
% Left camera = the camera, right camera = the projector (an inverse camera).


%-- Intrinsic parameters of left camera:

%-- Focal length:
fc_left = [ 760.000000000000000 ; 760.000000000000000 ];

%-- Principal point:
cc_left = [ 319.500000000000000 ; 239.500000000000000 ];

%-- Skew coefficient:
alpha_c_left = 0.000000000000000;

%-- Distortion coefficients:
kc_left = [ -0.120000000000000 ; 0.050000000000000 ; 0.001000000000000 ; -0.000800000000000 ; 0.000000000000000 ];

%-- Image size:
nx = 640;
ny = 480;


%-- Intrinsic parameters of right camera:

%-- Focal length:
fc_right = [ 1150.000000000000000 ; 1150.000000000000000 ];

%-- Principal point:
cc_right = [ 511.500000000000000 ; 383.500000000000000 ];

%-- Skew coefficient:
alpha_c_right = 0.000000000000000;

%-- Distortion coefficients:
kc_right = [ 0.060000000000000 ; -0.020000000000000 ; -0.000500000000000 ; 0.000400000000000 ; 0.000000000000000 ];


%-- Extrinsic parameters (position of right camera wrt left camera):

%-- Rotation vector:
om = [ -0.185851240088301 ; 0.182687121061350 ; 0.017073468341014 ];

%-- Translation vector:
T = [ -134.279907727176067 ; -138.972316383623820 ; 51.532530112066446 ];
