"""A simulated vehicle's files: its root directory held in a path jail, the virtual files
ArduPilot's AP_Filesystem adds (@PARAM/param.pck, @SYS, @MAV_LOG), staged (all-or-nothing)
writes, and the MAVFTP wire format and sessions that vehicle/link/ftp.py serves them with."""
