"""Other tools' files read as gaitcap's own types: keypoints (:mod:`.keypoint_files`, one entry for every
format; :mod:`.tool_folders` for Pose2Sim, anipose and FreeMoCap folders; :mod:`.openpose_json`,
:mod:`.mmpose_json`), board detections and calibrations (:mod:`.caliscope`, :mod:`.opencv_samples`), and
what every keypoint reader returns (:mod:`.keypoint_input`)."""
