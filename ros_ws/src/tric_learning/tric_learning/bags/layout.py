"""The layout of a TRIC demonstration bag: its topics and their types, which the bag recorder
(tric_learning.bags.recorder) writes and the dataset loader (tric_learning.bags.loader) reads.

A bag holds (topic: type):
    /tric/feature_definition: tric_msgs/FeatureDefinition   once, latched
    /tric/situation:          tric_msgs/Situation           once, latched
    /tric/samples:            tric_msgs/FeatureSample       one per sample (q, y, J, object poses)
    /joint_states:            sensor_msgs/JointState        every control period (raw)
    /object_poses:            tric_msgs/ObjectPoses         every control period (raw)
    /episode:                 tric_msgs/EpisodeEvent        START, END, OUTCOME (the teacher's
                                                            metrics)
    /controller/status:       tric_msgs/ControllerStatus    every control tick, when recording a
                                                            controller
and the scene topics for 3D replay (tric_learning.scene_recording: /robot_description, /tf_static,
/tf, /scene_markers), and in its rosbag2 custom data: tric.episode_id, tric.source, tric.task,
tric.fingerprint, tric.robot_profile (the robot profile's name and digest,
RobotProfile.identity) and, once known, tric.outcome (the metrics as JSON).
"""

from sensor_msgs.msg import JointState

from tric_msgs.msg import EpisodeEvent, FeatureSample, ObjectPoses
from tric_msgs.msg import FeatureDefinition as FeatureDefinitionMsg
from tric_msgs.msg import Situation as SituationMsg

DEFINITION_TOPIC = "/tric/feature_definition"
SITUATION_TOPIC = "/tric/situation"
SAMPLES_TOPIC = "/tric/samples"
TOPIC_TYPES = {
    DEFINITION_TOPIC: FeatureDefinitionMsg,
    SITUATION_TOPIC: SituationMsg,
    SAMPLES_TOPIC: FeatureSample,
    "/joint_states": JointState,
    "/object_poses": ObjectPoses,
    "/episode": EpisodeEvent,
}
